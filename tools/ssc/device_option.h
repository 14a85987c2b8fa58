// The --device option of the commands: cpu, cuda or auto (the default). Forward
// simulations run on the GPU with the generated kernels when asked or when auto finds a
// usable one; the adjoint (gradient, sweep, reconstruct) runs on the CPU for now.
#pragma once
#include <CLI/CLI.hpp>
#include <string>

namespace ssc {

class Simulation;

void add_device_option(CLI::App* sub, std::string* device);
// Puts a forward simulation on the chosen device; returns a description of it.
std::string place_forward_simulation(Simulation& sim, const std::string& device);
// For the commands whose adjoint runs on the CPU: rejects cuda, says so for auto.
std::string place_gradient_computation(const std::string& device);

}  // namespace ssc
