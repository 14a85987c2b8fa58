// The --device option of the commands: cpu, cuda or auto (the default). Simulations, and
// with them the adjoint (gradient, sweep, reconstruct), run on the GPU with the generated
// kernels when asked or when auto finds a usable one; auto falls back to the CPU with a
// one-line message, cuda without a usable GPU is an input error naming the reason. On the GPU a
// batch's items are shared among every visible GPU (CUDA_VISIBLE_DEVICES picks them; --gpus N
// takes the first N): models/sim/compute_device.h.
#pragma once
#include <CLI/CLI.hpp>
#include <string>

namespace ssc {

class Simulation;

// --device, and --gpus where the command shares batches among GPUs (gpus = true).
void add_device_option(CLI::App* sub, std::string* device, bool gpus = false);
// Puts a simulation on the chosen device (its first GPU); returns a description of it ("cpu" or the GPU).
std::string place_simulation(Simulation& sim, const std::string& device);
// For commands that build their simulations later (reconstruct): "cpu" or "cuda"
// (models/sim/compute_device.h).
std::string choose_device(const std::string& device);

}  // namespace ssc
