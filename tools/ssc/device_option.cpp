// --device handling (see device_option.h).
#include "tools/ssc/device_option.h"

#include <cstdio>

#include "runtime/errors.h"
#include "models/sim/compute_device.h"
#include "models/sim/simulation.h"
#include "runtime/cuda_runtime.h"
#include "tools/ssc/progress.h"

namespace ssc {

void add_device_option(CLI::App* sub, std::string* device, bool gpus) {
  sub->add_option("--device", *device, "cpu, cuda or auto (GPU when usable, else CPU)")
      ->check(CLI::IsMember({"cpu", "cuda", "auto"}));
  if (gpus)
    sub->add_option_function<int>(
           "--gpus", [](const int& n) { set_gpu_limit(n); },
           "Share each batch among the first N visible GPUs (default: all; CUDA_VISIBLE_DEVICES picks them)")
        ->check(CLI::PositiveNumber);
}

std::string choose_device(const std::string& device) {
  if (device == "cpu") return "cpu";
  const std::string why = gpu_unavailable_reason();
  if (why.empty()) {
    note("running on " + describe_device("cuda"));
    return "cuda";
  }
  if (device == "cuda") throw GpuError("--device cuda: " + why + "; use --device cpu or --device auto");
  note(why + "; running on the CPU");
  return "cpu";
}

std::string place_simulation(Simulation& sim, const std::string& device) {
  if (choose_device(device) == "cpu") return "cpu";
  try {
    place_on(sim, "cuda");
  } catch (const GpuUnavailable& e) {
    if (device == "cuda") throw GpuError(std::string("--device cuda: ") + e.what() + "; use --device cpu or --device auto");
    note(std::string(e.what()) + "; running on the CPU");
    return "cpu";
  }
  return gpu_description(device_gpus("cuda").front());
}

}  // namespace ssc
