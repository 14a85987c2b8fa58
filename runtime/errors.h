// Error types that reach the user. An InputError is the user's to fix (a bad scene,
// a missing file, a mesh that cannot be turned into an SDF); its message names the
// file, the key and the fix. A SimulationError reports a run that went wrong (a solver
// that did not converge, an exploding state, energy gained) with the step it happened in.
// A GpuError: the GPU asked for cannot be used. The exit code of each is in ExitCode.
#pragma once
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace ssc {

struct InputError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

struct SimulationError : std::runtime_error {
  explicit SimulationError(const std::string& what, std::vector<int> batch_items = {})
      : std::runtime_error(what), items(std::move(batch_items)) {}
  // The batch items that went wrong, where known (empty: not known, or the whole batch):
  // a batched fit drops those and runs the others on together.
  std::vector<int> items;
};

struct GpuError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// The exit codes of the ssc binary (docs/cli.md); 128 + signal for an interrupted run.
enum ExitCode : int {
  kExitSuccess = 0,
  kExitUsage = 1,       // the command line itself (unknown option, missing argument)
  kExitInput = 2,       // a file, key or value to fix; an output folder that is not ssc's
  kExitSimulation = 3,  // a run that went wrong (explosion, energy gain, no start converged)
  kExitGpu = 4,         // --device cuda without a usable GPU, a kernel that NVRTC rejects
  kExitInternal = 5,    // a bug in ssc: please report it
};

}  // namespace ssc
