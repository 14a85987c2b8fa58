// A one-line progress display on a terminal; silent when stderr is not a terminal.
#pragma once
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <string>

namespace ssc {

class Progress {
 public:
  Progress(std::string label, int total)
      : label_(std::move(label)), total_(total), enabled_(isatty(fileno(stderr))), start_(std::chrono::steady_clock::now()) {}
  void update(int done, const std::string& detail = "") {
    if (!enabled_) return;
    const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
    std::fprintf(stderr, "\r%s %d/%d (%.1f s) %s\033[K", label_.c_str(), done, total_, s, detail.c_str());
    std::fflush(stderr);
  }
  void finish() {
    if (enabled_) std::fprintf(stderr, "\n");
  }

 private:
  std::string label_;
  int total_;
  bool enabled_;
  std::chrono::steady_clock::time_point start_;
};

}  // namespace ssc
