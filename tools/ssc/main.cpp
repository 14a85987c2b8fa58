// ssc command-line entry point: dispatches to the subcommands and turns errors into
// one clear message and a non-zero exit code.
#include <fmt/format.h>

#include <CLI/CLI.hpp>
#include <cstdio>

#include "models/io/errors.h"
#include "tools/ssc/commands.h"

int main(int argc, char** argv) {
  CLI::App app{fmt::format("ssc {}: physical parameters from sparse surface constraints", SSC_VERSION)};
  app.require_subcommand(1);
  app.set_version_flag("--version", SSC_VERSION);
  std::vector<std::pair<CLI::App*, ssc::Command>> commands;
  auto add = [&](ssc::Command (*reg)(CLI::App&)) {
    const size_t before = app.get_subcommands({}).size();
    ssc::Command run = reg(app);
    commands.emplace_back(app.get_subcommands({})[before], std::move(run));
  };
  add(ssc::register_simulate);
  add(ssc::register_observe);
  add(ssc::register_gradient);
  add(ssc::register_sweep);
  add(ssc::register_reconstruct);
  add(ssc::register_kernels);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  }
  try {
    for (auto& [sub, run] : commands)
      if (sub->parsed()) return run();
  } catch (const ssc::InputError& e) {
    std::fprintf(stderr, "ssc: error: %s\n", e.what());
    return 2;
  } catch (const ssc::SimulationError& e) {
    std::fprintf(stderr, "ssc: simulation failed: %s\n", e.what());
    return 3;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "ssc: internal error: %s\n", e.what());
    return 4;
  }
  return 1;
}
