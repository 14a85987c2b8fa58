// Devices by name (see compute_device.h).
#include "models/sim/compute_device.h"

#include <fmt/format.h>

#include <algorithm>
#include <atomic>
#include <cstdlib>
#include <exception>
#include <thread>

#include "models/sim/simulation.h"
#include "runtime/cuda_runtime.h"
#include "runtime/errors.h"
#include "runtime/ranks.h"

namespace ssc {
namespace {

std::atomic<int> gpu_limit{0};

}  // namespace

bool runs_on_gpu(const std::string& device) { return device.rfind("cuda", 0) == 0; }

std::string gpu_device(int ordinal) { return fmt::format("cuda:{}", ordinal); }

void set_gpu_limit(int n) { gpu_limit = std::max(0, n); }

std::vector<int> device_gpus(const std::string& device) {
  if (device == "cpu") return {};
  if (device.rfind("cuda:", 0) == 0) {
    char* end = nullptr;
    const long k = std::strtol(device.c_str() + 5, &end, 10);
    if (end == device.c_str() + 5 || *end || k < 0) throw InputError("device '" + device + "': expected cuda:K, K >= 0");
    return {int(k)};
  }
  if (device != "cuda") throw InputError("device '" + device + "': expected cpu, cuda or cuda:K");
  int n = gpu_count();
  if (gpu_limit > 0) n = std::min(n, gpu_limit.load());
  if (n <= 0) return {0};  // the GPU's construction then says why there is none
  std::vector<int> mine;
  const int ranks = ranks::local_count(), me = ranks::local_rank();
  for (int g = me; g < n; g += ranks) mine.push_back(g);
  if (mine.empty()) mine.push_back(me % n);
  return mine;
}

void side_by_side(size_t count, const std::string& device, const std::function<void(size_t, const std::string&)>& fn) {
  const std::vector<int> gpus = runs_on_gpu(device) && ranks::count() == 1 ? device_gpus(device) : std::vector<int>{};
  std::vector<std::exception_ptr> failures(count);
  auto run = [&](size_t k, const std::string& on) {
    try {
      fn(k, on);
    } catch (...) {
      failures[k] = std::current_exception();
    }
  };
  if (gpus.empty() || count <= 1) {
    for (size_t k = 0; k < count; ++k) run(k, device);
  } else {
    std::vector<std::thread> workers;
    for (size_t k = 0; k < count; ++k) workers.emplace_back([&, k] { run(k, gpu_device(gpus[k % gpus.size()])); });
    for (std::thread& w : workers) w.join();
  }
  for (const std::exception_ptr& f : failures)
    if (f) std::rethrow_exception(f);
}

std::string describe_device(const std::string& device) {
  std::string d = "cpu";
  if (runs_on_gpu(device)) {
    const std::vector<int> gpus = device_gpus(device);
    d = gpu_description(gpus.front());
    bool same = true;
    for (int g : gpus) same &= gpu_description(g) == d;
    std::string list;
    for (int g : gpus) list += (list.empty() ? "" : ", ") + std::to_string(g);
    if (gpus.size() > 1)
      d = same ? fmt::format("{} x {} (GPUs {})", gpus.size(), d, list) : fmt::format("{} GPUs ({})", gpus.size(), list);
  }
  if (ranks::count() > 1) d += fmt::format(", MPI rank {} of {}", ranks::rank(), ranks::count());
  return d;
}

void place_on(Simulation& sim, const std::string& device, const std::string& real) {
  if (runs_on_gpu(device)) sim.use_gpu(real, device_gpus(device).front());
}

}  // namespace ssc
