// Error types that reach the user. An InputError is the user's to fix (a bad scene,
// a missing file, a mesh that cannot be turned into an SDF); its message names the
// file, the key and the fix. A SimulationError reports a run that went wrong (a solver
// that did not converge, an exploding state) with the step it happened in.
#pragma once
#include <stdexcept>
#include <string>

namespace ssc {

struct InputError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

struct SimulationError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

}  // namespace ssc
