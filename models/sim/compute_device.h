// Where a run's simulations go, as a resolved --device names it (tools/ssc/device_option.h
// resolves "auto"): "cpu"; "cuda", every GPU this rank may use; "cuda:K", GPU K alone (one
// worker of a batch split over GPUs, models/sim/batch_workers.h, or one of diagnose's fits run
// side by side). The GPUs a rank may use: those the driver lists (CUDA_VISIBLE_DEVICES picks
// them), the first --gpus of them (set_gpu_limit), and, where MPI started several ranks on one
// host, every local_count-th of those from the rank's local rank (a rank keeps one GPU at
// least, shared round robin where there are more ranks than GPUs).
#pragma once
#include <functional>
#include <string>
#include <vector>

namespace ssc {

class Simulation;

bool runs_on_gpu(const std::string& device);
// The GPU ordinals of `device` ({} for "cpu"); throws InputError for a malformed name.
std::vector<int> device_gpus(const std::string& device);
std::string gpu_device(int ordinal);  // "cuda:K"
// At most n GPUs per process (--gpus; 0: all).
void set_gpu_limit(int n);
// "cpu", "NVIDIA H100 80GB HBM3 (sm_90)", "2 x NVIDIA H100 80GB HBM3 (sm_90) (GPUs 0, 1)", with
// ", MPI rank R of K" where several ranks share the run (each rank names its own GPUs).
std::string describe_device(const std::string& device);
// fn(k, device of k) for every k < count. On the GPU with one rank, each k in a thread of its
// own, on the device's GPUs round robin; otherwise one after another on `device`. Every call
// finishes before the first exception thrown is rethrown. For independent evaluations whose
// results do not depend on the GPU that computes them.
void side_by_side(size_t count, const std::string& device, const std::function<void(size_t, const std::string&)>& fn);
// The simulation on the device's first GPU, or left on the CPU.
void place_on(Simulation& sim, const std::string& device, const std::string& real = "double");

}  // namespace ssc
