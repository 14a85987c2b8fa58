// The time axis of a recording: its timestamps (jittery, maybe with dropped frames) mapped
// onto a regular frame interval, as the observation format's frame_times and a simulation's
// steps need them. Each interval between two kept frames must be close to a whole number of
// nominal intervals (the median interval): one is the next frame, more is a gap of dropped
// frames (warning dropped_frames); anything else is irregular timing and an InputError.
#pragma once
#include <string>
#include <vector>

namespace ssc {

struct FrameTiming {
  double frame_dt = 0;           // s, the nominal interval
  std::vector<int> frame_index;  // per kept frame: its time is frame_index[f] * frame_dt after frame 0
  int dropped = 0;               // frames missing in the gaps
};

// timestamps: s, strictly increasing; fallback_dt: the interval for a single frame.
// `where` names the timestamps' source in messages.
FrameTiming regularise_timestamps(const std::vector<double>& timestamps, double fallback_dt, const std::string& where);

}  // namespace ssc
