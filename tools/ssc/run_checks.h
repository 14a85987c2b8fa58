// Warnings the commands raise from what a finished simulation saw (models/sim/run_audit.h).
#pragma once

namespace ssc {

class Simulation;

// A warning (recorded) for every batch item in which cells inverted: count and first step.
void report_inverted_cells(const Simulation& sim);

}  // namespace ssc
