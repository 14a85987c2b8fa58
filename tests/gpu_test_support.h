// Shared by the tests that compile or run generated kernels: one kernel cache per test
// process, the torus scene, and the skip for machines without a usable GPU.
#pragma once
#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <string>
#include <vector>

#include "models/sim/scene.h"
#include "runtime/cuda_runtime.h"
#include "runtime/interpreter.h"

namespace ssc {

inline const std::string& test_cache_root() {
  static const std::string dir = [] {
    namespace fs = std::filesystem;
    const fs::path p = fs::temp_directory_path() / ("ssc-test-kernels-" + std::to_string(getpid()));
    fs::create_directories(p);
    setenv("SSC_KERNEL_CACHE", p.c_str(), 1);
    return p.string();
  }();
  return dir;
}

// The GPU's solver options for a comparison with the interpreter: the interpreter factors the
// band Laplacian (runtime/band_factor.h), so in double the GPU's extension PCG runs to 1e-13
// to agree within the tests' 1e-10 (float keeps the scene's tolerance, which it can reach).
inline SolverOptions gpu_options_against_interpreter(SolverOptions so, const std::string& real) {
  if (real == "double") so.extension_tolerance = 1e-13;
  return so;
}

inline Scene torus_scene(const std::vector<std::string>& overrides = {}) {
  return load_scene(std::string(SSC_SOURCE_DIR) + "/examples/torus.json", overrides);
}

}  // namespace ssc

#define SKIP_WITHOUT_GPU()                            \
  do {                                                \
    const std::string why = ssc::gpu_unavailable_reason(); \
    if (!why.empty()) GTEST_SKIP() << why;            \
  } while (0)
