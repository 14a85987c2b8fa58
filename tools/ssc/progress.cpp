// Progress lines and notes (see progress.h).
#include "tools/ssc/progress.h"

#include <fmt/format.h>
#include <unistd.h>

#include <cstdio>

namespace ssc {
namespace {

std::string duration(double s) {
  if (s < 90) return fmt::format("{:.1f} s", s);
  if (s < 5400) return fmt::format("{:.1f} min", s / 60);
  return fmt::format("{:.1f} h", s / 3600);
}
}  // namespace

void add_progress_options(CLI::App* sub, ProgressMode* mode) {
  auto* lines = sub->add_flag_callback("--progress", [mode] { *mode = ProgressMode::Lines; },
                                       "Print a progress line per round on stderr, also when it is not a terminal");
  sub->add_flag_callback("--quiet", [mode] { *mode = ProgressMode::Quiet; set_quiet(true); },
                         "No progress, notes or warnings on stderr (warnings stay in the output's JSON); only "
                         "errors and the result")
      ->excludes(lines);
}

Progress::Progress(std::string label, int total, ProgressMode mode, double min_interval_s)
    : label_(std::move(label)),
      total_(total),
      mode_(mode),
      terminal_(isatty(fileno(stderr))),
      min_interval_s_(min_interval_s),
      start_(std::chrono::steady_clock::now()) {}

void Progress::update(int done, const std::string& detail) {
  if (mode_ == ProgressMode::Quiet || (mode_ == ProgressMode::Auto && !terminal_)) return;
  const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
  const std::string rest = done > 0 && done < total_ ? ", about " + duration(s / done * (total_ - done)) + " left" : "";
  const std::string line = fmt::format("{} {}/{} ({} elapsed{}) {}", label_, done, total_, duration(s), rest, detail);
  if (mode_ == ProgressMode::Auto) {
    std::fprintf(stderr, "\r%s\033[K", line.c_str());
  } else {
    if (s - last_line_s_ < min_interval_s_ && done < total_) return;
    last_line_s_ = s;
    std::fprintf(stderr, "%s\n", line.c_str());
  }
  std::fflush(stderr);
}

void Progress::stage(const std::string& what) {
  if (mode_ == ProgressMode::Quiet) return;
  const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
  std::fprintf(stderr, "%s: %s (%s elapsed)\n", label_.c_str(), what.c_str(), duration(s).c_str());
  std::fflush(stderr);
}

void Progress::finish() {
  if (mode_ == ProgressMode::Auto && terminal_) std::fprintf(stderr, "\n");
}

}  // namespace ssc
