// Where the CLI tests find the `ssc` binary: beside the test binary (build/bin/).
#pragma once
#include <unistd.h>

#include <filesystem>
#include <string>

namespace ssc {

inline std::string ssc_binary_path() {
  char buf[4096];
  const ssize_t n = readlink("/proc/self/exe", buf, sizeof buf - 1);
  if (n <= 0) return "";
  buf[n] = 0;
  return (std::filesystem::path(buf).parent_path() / "ssc").string();
}

}  // namespace ssc
