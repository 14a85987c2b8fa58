#include "models/recording/frame_timing.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "models/io/run_record.h"
#include "runtime/errors.h"

namespace ssc {

namespace {
// How far an interval may be from a whole number of nominal intervals (sensor clocks jitter
// by a few milliseconds at 30 frames per second; a third of an interval is not jitter).
constexpr double kJitter = 0.3;
}  // namespace

FrameTiming regularise_timestamps(const std::vector<double>& t, double fallback_dt, const std::string& where) {
  FrameTiming timing;
  timing.frame_index.assign(t.size(), 0);
  if (t.size() < 2) {
    timing.frame_dt = fallback_dt;
    return timing;
  }
  std::vector<double> gaps;
  for (size_t f = 1; f < t.size(); ++f) gaps.push_back(t[f] - t[f - 1]);
  std::vector<double> sorted = gaps;
  std::nth_element(sorted.begin(), sorted.begin() + sorted.size() / 2, sorted.end());
  const double nominal = sorted[sorted.size() / 2];
  if (!(nominal > 0))
    throw InputError(fmt::format("{}: the timestamps do not increase (median interval {} s)", where, nominal));
  for (size_t f = 1; f < t.size(); ++f) {
    const double steps = gaps[f - 1] / nominal;
    const double whole = std::round(steps);
    if (whole < 1 || std::abs(steps - whole) > kJitter)
      throw InputError(fmt::format(
          "{}: irregular timestamps: frames {} and {} are {:.6g} s apart, {:.2f} times the usual interval of {:.6g} s "
          "({:.1f} frames per second); a recording must have a steady frame rate, with at most whole frames dropped: "
          "cut the recording with --frames, or fix the timestamps", where, f - 1, f, gaps[f - 1], steps, nominal,
          1 / nominal));
    timing.frame_index[f] = timing.frame_index[f - 1] + int(whole);
    timing.dropped += int(whole) - 1;
  }
  // The interval that best fits every timestamp (least squares through frame 0).
  double num = 0, den = 0;
  for (size_t f = 1; f < t.size(); ++f) {
    num += (t[f] - t[0]) * timing.frame_index[f];
    den += double(timing.frame_index[f]) * timing.frame_index[f];
  }
  timing.frame_dt = num / den;
  if (timing.dropped > 0)
    warn("dropped_frames", fmt::format("{}: {} frames are missing (gaps in the timestamps); their times are kept as "
                                       "gaps in frame_times", where, timing.dropped));
  return timing;
}

}  // namespace ssc
