// --device handling (see device_option.h).
#include "tools/ssc/device_option.h"

#include <cstdio>

#include "runtime/errors.h"
#include "models/sim/simulation.h"
#include "runtime/cuda_runtime.h"
#include "tools/ssc/progress.h"

namespace ssc {

void add_device_option(CLI::App* sub, std::string* device) {
  sub->add_option("--device", *device, "cpu, cuda or auto (GPU when usable, else CPU)")
      ->check(CLI::IsMember({"cpu", "cuda", "auto"}));
}

std::string choose_device(const std::string& device) {
  if (device == "cpu") return "cpu";
  const std::string why = gpu_unavailable_reason();
  if (why.empty()) {
    note("running on " + gpu_description());
    return "cuda";
  }
  if (device == "cuda") throw GpuError("--device cuda: " + why + "; use --device cpu or --device auto");
  note(why + "; running on the CPU");
  return "cpu";
}

std::string place_simulation(Simulation& sim, const std::string& device) {
  if (choose_device(device) == "cpu") return "cpu";
  try {
    sim.use_gpu();
  } catch (const GpuUnavailable& e) {
    if (device == "cuda") throw GpuError(std::string("--device cuda: ") + e.what() + "; use --device cpu or --device auto");
    note(std::string(e.what()) + "; running on the CPU");
    return "cpu";
  }
  return gpu_description();
}

}  // namespace ssc
