// ssc command-line entry point: dispatches to the subcommands and turns every error into
// one clear message and its exit code (runtime/errors.h, docs/cli.md).
#include <fmt/format.h>

#include <CLI/CLI.hpp>
#include <cstdio>

#include "runtime/errors.h"
#include "models/io/run_record.h"
#include "runtime/cuda_runtime.h"
#include "runtime/nvrtc_compiler.h"
#include "tools/ssc/commands.h"
#include "tools/ssc/interrupts.h"

namespace {

int report(const char* kind, const std::exception& e, int code) {
  std::fprintf(stderr, "ssc: %s: %s\n", kind, e.what());
  return code;
}

}  // namespace

int main(int argc, char** argv) {
  ssc::handle_interrupts();
  ssc::set_command_line(argc, argv);
  CLI::App app{fmt::format("ssc {}: physical parameters from sparse surface constraints", SSC_VERSION)};
  app.require_subcommand(1);
  app.set_version_flag("--version", SSC_VERSION);
  app.footer("Exit codes: 0 success, 1 usage error, 2 input error, 3 simulation error, 4 GPU/NVRTC error, "
             "5 internal error, 130/143 interrupted (docs/cli.md).");
  app.option_defaults()->always_capture_default();  // --help shows every default
  std::vector<std::pair<CLI::App*, ssc::Command>> commands;
  auto add = [&](ssc::Command (*reg)(CLI::App&)) {
    const size_t before = app.get_subcommands({}).size();
    ssc::Command run = reg(app);
    commands.emplace_back(app.get_subcommands({})[before], std::move(run));
  };
  add(ssc::register_simulate);
  add(ssc::register_observe);
  add(ssc::register_render);
  add(ssc::register_gradient);
  add(ssc::register_sweep);
  add(ssc::register_reconstruct);
  add(ssc::register_kernels);
  add(ssc::register_residuals);
  add(ssc::register_diagnose);
  if (argc > 1 && argv[1][0] != '-') {
    std::string names;
    bool known = false;
    for (auto& [sub, run] : commands) {
      known |= sub->get_name() == argv[1];
      names += (names.empty() ? "" : ", ") + sub->get_name();
    }
    if (!known) {
      std::fprintf(stderr, "ssc: unknown command '%s'; the commands are %s (ssc --help)\n", argv[1], names.c_str());
      return ssc::kExitUsage;
    }
  }
  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForAllHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForVersion& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    app.exit(e);  // prints the message and the usage
    return ssc::kExitUsage;
  }
  try {
    for (auto& [sub, run] : commands)
      if (sub->parsed()) return run();
  } catch (const ssc::InputError& e) {
    return report("error", e, ssc::kExitInput);
  } catch (const ssc::SimulationError& e) {
    return report("simulation failed", e, ssc::kExitSimulation);
  } catch (const ssc::GpuError& e) {
    return report("GPU error", e, ssc::kExitGpu);
  } catch (const ssc::GpuUnavailable& e) {
    return report("GPU error", e, ssc::kExitGpu);
  } catch (const ssc::NvrtcError& e) {
    return report("kernel compilation failed (NVRTC)", e, ssc::kExitGpu);
  } catch (const std::bad_alloc& e) {
    std::fprintf(stderr, "ssc: error: out of memory; use a coarser grid, fewer starts or a shorter run\n");
    return ssc::kExitInput;
  } catch (const std::exception& e) {
    return report("internal error (please report it)", e, ssc::kExitInternal);
  }
  return ssc::kExitUsage;
}
