#pragma once
// How the phase table times a phase, a setting of the case (output/phase_timers) that the timers
// (phase_timers.hpp) take: apart from case_config.hpp, so that the timers need nothing else of it.

namespace mpmflow {

// How the phase table times a phase (PhaseTimers): `fenced` waits for the phase's kernels at its end,
// so that each phase is charged its own work on a back-end that runs kernels asynchronously (a
// GPU), at the price of a wait the next phase's launches cannot overlap, 18 a step; `unfenced` takes
// the host's time in the phase, with nothing added to the step (on CPU back-ends, whose launches
// return when their work is done, the two are the same).
enum class PhaseTiming { fenced, unfenced };

}  // namespace mpmflow
