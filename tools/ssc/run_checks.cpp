// Warnings from the run audit (see run_checks.h).
#include "tools/ssc/run_checks.h"

#include <fmt/format.h>

#include "models/io/run_record.h"
#include "models/sim/simulation.h"

namespace ssc {

void report_inverted_cells(const Simulation& sim) {
  for (int b = 0; b < sim.batch(); ++b) {
    const SimulationAudit& a = sim.audit(b);
    if (a.inverted_cells == 0) continue;
    warn("inverted_cells",
         fmt::format("{} of {} cells inverted (det F <= 0) at the worst step, first at step {}{}: the body is squashed "
                     "through itself, so its forces there are meaningless; raise material.youngs_modulus, lower time.dt "
                     "or soften the contact",
                     a.inverted_cells, sim.grid().cell_count, a.first_inverted_step,
                     sim.batch() > 1 ? fmt::format(" (batch item {})", b) : ""));
  }
}

}  // namespace ssc
