// The inputs of `ssc render`: a sequence of mesh frames named on the command line (files,
// folders, glob patterns), ordered by file name, and the times of its frames.
#pragma once
#include <string>
#include <vector>

namespace ssc {

// The mesh files the arguments name: a folder stands for every .ply file in it, an argument
// with * ? or [ that is not an existing file is a glob pattern, anything else one file. The
// list is sorted by file name with digit runs compared as numbers (frame_9 before
// frame_10). InputError for a missing file, a folder or pattern without .ply files, a file
// named twice, or a file that is not .ply.
std::vector<std::string> list_mesh_frames(const std::vector<std::string>& arguments);

// Evenly spaced frame times, as the observation format holds them.
struct FrameTimes {
  double first = 0;  // s, time of frame 0
  double dt = 0;     // s, between frames
};

// From exactly one of fps (> 0), dt (> 0) or a times file (one time in seconds per line or
// a JSON array of numbers; '#' starts a comment), given as 0 / 0 / "" when absent; `first`
// is the time of frame 0 with fps and dt. A times file must list one time per frame,
// increasing and evenly spaced (to 1e-6 of the interval): the observation format has no
// per-frame times. InputError naming the option or file otherwise.
FrameTimes frame_times(int frames, double fps, double dt, const std::string& times_file, double first);

}  // namespace ssc
