// ssc command-line entry point: dispatches to the subcommands and turns every error into
// one clear message and its exit code (runtime/errors.h, docs/cli.md).
#include <fcntl.h>
#include <fmt/format.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <cstdio>
#include <exception>
#include <filesystem>

#include "runtime/errors.h"
#include "runtime/ranks.h"
#include "models/sim/batch_workers.h"
#include "models/io/notes.h"
#include "models/io/run_record.h"
#include "models/io/write_error.h"
#include "runtime/cuda_runtime.h"
#include "runtime/nvrtc_compiler.h"
#include "tools/ssc/commands.h"
#include "tools/ssc/interrupts.h"

namespace {

// A failed command's message ("ssc: KIND: ...") and exit code.
int describe_failure(const std::exception_ptr& failure, std::string* error) {
  auto fail = [error](const char* kind, const std::string& what, int code) {
    *error = fmt::format("ssc: {}: {}", kind, what);
    return code;
  };
  try {
    std::rethrow_exception(failure);
  } catch (const ssc::InputError& e) {
    return fail("error", e.what(), ssc::kExitInput);
  } catch (const ssc::SimulationError& e) {
    return fail("simulation failed", e.what(), ssc::kExitSimulation);
  } catch (const ssc::GpuError& e) {
    return fail("GPU error", e.what(), ssc::kExitGpu);
  } catch (const ssc::GpuUnavailable& e) {
    return fail("GPU error", e.what(), ssc::kExitGpu);
  } catch (const ssc::NvrtcError& e) {
    return fail("kernel compilation failed (NVRTC)", e.what(), ssc::kExitGpu);
  } catch (const std::filesystem::filesystem_error& e) {
    return fail("error", ssc::filesystem_error_message(e), ssc::kExitInput);
  } catch (const std::bad_alloc&) {
    return fail("error", "out of memory; use a coarser grid, fewer starts or a shorter run", ssc::kExitInput);
  } catch (const std::exception& e) {
    return fail("internal error (please report it)", e.what(), ssc::kExitInternal);
  } catch (...) {
    return fail("internal error (please report it)", "an unknown exception", ssc::kExitInternal);
  }
}

// Under MPI every rank but 0 runs silently, its stdout and stderr going to /dev/null: rank 0
// prints the progress, the result and any rank's error (ssc::agree_on_outcome).
void quiet_other_ranks() {
  if (ssc::ranks::rank() == 0) return;
  const int null = ::open("/dev/null", O_WRONLY);
  if (null >= 0) {
    std::fflush(stdout);
    std::fflush(stderr);
    ::dup2(null, 1);
    ::dup2(null, 2);
    ::close(null);
  }
}

// Parses and runs the command: its exit code, or the exception that ended it in *failure.
int run_main(int argc, char** argv, std::exception_ptr* failure) {
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
  add(ssc::register_prepare);
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
  ssc::hold_warnings();  // printed together at the end, after any progress line
  try {
    for (auto& [sub, run] : commands)
      if (sub->parsed()) return run();
  } catch (...) {
    *failure = std::current_exception();
    return ssc::kExitInternal;
  }
  return ssc::kExitUsage;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    ssc::ranks::start(&argc, &argv);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "ssc: error: %s\n", e.what());
    return ssc::kExitInput;
  }
  quiet_other_ranks();
  std::exception_ptr failure;
  int code = run_main(argc, argv, &failure);
  failure = ssc::agree_on_outcome(failure);  // several ranks: a failure on one ends them all
  if (!ssc::quiet()) ssc::print_held_warnings();
  if (failure) {
    std::string error;
    code = describe_failure(failure, &error);
    std::fprintf(stderr, "%s\n", error.c_str());
  }
  ssc::ranks::finish();
  return code;
}
