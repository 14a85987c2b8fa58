// Progress of long commands. Auto (default): one line rewritten in place when stderr is a
// terminal, nothing otherwise. --progress: a line per update on stderr even when it is not a
// terminal (nohup, batch systems), with the count, elapsed time and an estimate of the rest.
// Stages whose share of the run is not known ahead (diagnose, residuals) get a line each with
// the time elapsed, in both modes. --quiet: no progress, no notes (models/io/notes.h) and no
// warnings on stderr (they stay in the outputs' JSON); only errors and the result.
#pragma once
#include <CLI/CLI.hpp>
#include <chrono>
#include <string>

#include "models/io/notes.h"

namespace ssc {

enum class ProgressMode { Auto, Lines, Quiet };

void add_progress_options(CLI::App* sub, ProgressMode* mode);

class Progress {
 public:
  // min_interval_s: in Lines mode, at most one line per this many seconds (the last always).
  Progress(std::string label, int total, ProgressMode mode, double min_interval_s = 1.0);
  void update(int done, const std::string& detail = "");
  // "LABEL: WHAT (T elapsed)" on a line of its own, unless --quiet.
  void stage(const std::string& what);
  void finish();

 private:
  std::string label_;
  int total_;
  ProgressMode mode_;
  bool terminal_;
  double min_interval_s_, last_line_s_ = -1e9;
  std::chrono::steady_clock::time_point start_;
};

}  // namespace ssc
