// The ssc subcommands. Each registers its options on the CLI11 app and returns the
// function that runs it.
#pragma once
#include <CLI/CLI.hpp>
#include <functional>

namespace ssc {

using Command = std::function<int()>;

Command register_simulate(CLI::App& app);
Command register_observe(CLI::App& app);
Command register_render(CLI::App& app);
Command register_gradient(CLI::App& app);
Command register_sweep(CLI::App& app);
Command register_reconstruct(CLI::App& app);
Command register_kernels(CLI::App& app);
Command register_residuals(CLI::App& app);
Command register_diagnose(CLI::App& app);
Command register_prepare(CLI::App& app);

}  // namespace ssc
