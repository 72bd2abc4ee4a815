// Links the installed solver library: loads a shipped case and steps a small solver once.
#include <cstdio>

#include "case_config.hpp"
#include "particles.hpp"
#include "solver.hpp"

int main(int argc, char** argv) {
  Kokkos::initialize(argc, argv);
  int status = 0;
  {
    const mpmflow::CaseConfig config =
        mpmflow::load_case_file(std::string(CASES_DIR) + "/sod.json", {"domain/cells_x=20", "output/snapshots=0"});
    const mpmflow::GridSlab slab = mpmflow::make_grid_slab(config.domain, 0, config.domain.cells_x);
    mpmflow::Solver solver(config, slab, mpmflow::create_initial_particles(config, slab));
    const double t = solver.step_towards(0.0, 1.0);
    std::printf("consumer: case %s, %d cells, %ld particles, one step to t = %g\n", config.name.c_str(),
                config.domain.cells_x, static_cast<long>(solver.particles().count), t);
    status = t > 0 ? 0 : 1;
  }
  Kokkos::finalize();
  return status;
}
