// A test fixture for the CLI tests: a fresh folder per test (kept when the test fails, to
// look at), scene files written into it, and `ssc` run with its exit code and output.
#pragma once
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "tests/ssc_binary.h"

namespace ssc {

inline std::string read_text(const std::filesystem::path& p) {
  std::ifstream in(p);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

inline nlohmann::json read_json(const std::filesystem::path& p) {
  std::ifstream in(p);
  return nlohmann::json::parse(in);
}

class CliTestFolder : public ::testing::Test {
 protected:
  explicit CliTestFolder(std::string prefix) : prefix_(std::move(prefix)) {}
  void SetUp() override {
    const std::string test = ::testing::UnitTest::GetInstance()->current_test_info()->name();
    dir_ = std::filesystem::temp_directory_path() / (prefix_ + std::to_string(getpid()) + "-" + test);
    std::filesystem::remove_all(dir_);
    std::filesystem::create_directories(dir_);
    binary_ = ssc_binary_path();
    ASSERT_TRUE(std::filesystem::exists(binary_)) << "the ssc binary is not next to the test binary: " << binary_;
  }
  void TearDown() override {
    std::error_code ec;
    if (!HasFailure()) std::filesystem::remove_all(dir_, ec);  // a failed test keeps its folder to look at
  }
  std::string write(const std::string& name, const nlohmann::json& scene) {
    const std::filesystem::path p = dir_ / name;
    std::ofstream(p) << scene.dump(2);
    return p.string();
  }
  // Runs ssc with the arguments; returns the exit code, stdout in *out and stderr in *err. One
  // OpenMP thread unless OMP_NUM_THREADS says otherwise: the engine's many small parallel regions
  // slow down many times over on cores shared with other processes (a reconstruction measured
  // 9 s on 2 idle cores, 15 s on one thread, up to 65 s on 2 threads at load 5).
  int run(const std::string& args, std::string* out, std::string* err) {
    return run_with_prefix("OMP_NUM_THREADS=\"${OMP_NUM_THREADS:-1}\"", args, out, err);
  }
  // The same with `prefix` (environment settings, a launcher) before the binary.
  int run_with_prefix(const std::string& prefix, const std::string& args, std::string* out, std::string* err) {
    const std::filesystem::path o = dir_ / "stdout.txt", e = dir_ / "stderr.txt";
    const std::string cmd = prefix + " '" + binary_ + "' " + args + " > '" + o.string() + "' 2> '" + e.string() + "'";
    const int status = std::system(cmd.c_str());
    *out = read_text(o);
    *err = read_text(e);
    return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  }
  // Unfinished outputs (".OUT.ssc-tmp-PID") left in the folder.
  std::vector<std::string> leftovers() const {
    std::vector<std::string> found;
    for (const auto& e : std::filesystem::directory_iterator(dir_))
      if (e.path().filename().string().find(".ssc-tmp-") != std::string::npos) found.push_back(e.path().string());
    return found;
  }
  std::filesystem::path dir_;
  std::string binary_;

 private:
  std::string prefix_;
};

}  // namespace ssc
