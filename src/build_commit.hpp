#pragma once
#include <string>

namespace mpmflow {

// The git commit the sources were at when this binary was built (`git describe --always --dirty`,
// "-dirty" for uncommitted changes), or "unknown commit" outside a git checkout. Defined in a
// source file that every build rewrites when the commit changed (cmake/MpmflowBuildCommit.cmake).
const char* build_commit();

// "mpmflow <version> (<commit>)": the banner's first words, and what wrote a snapshot or a
// checkpoint (their attribute mpmflow_build).
inline std::string build_identity() { return std::string("mpmflow ") + MPMFLOW_VERSION + " (" + build_commit() + ")"; }

}  // namespace mpmflow
