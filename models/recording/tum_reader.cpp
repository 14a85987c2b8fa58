// The TUM RGB-D benchmark's layout: DIR/depth.txt lists "timestamp filename" per frame
// ('#' comments), the PNGs hold 5000 units per metre. The timestamps are the file's. The
// dataset ships no intrinsics file: --intrinsics, an intrinsic.json in the folder, or, for a
// folder named after one of its Kinects (freiburg1/2/3), the published calibration.
#include <fmt/format.h>

#include <filesystem>
#include <fstream>
#include <sstream>

#include "models/io/notes.h"
#include "models/recording/recording_readers.h"
#include "runtime/errors.h"

namespace fs = std::filesystem;

namespace ssc {

namespace {

// The TUM RGB-D benchmark's published depth intrinsics (vision.in.tum.de, "file formats").
bool published_tum_intrinsics(const std::string& folder, DepthIntrinsics* k, std::string* source) {
  const std::string name = fs::absolute(folder).lexically_normal().string();
  struct Camera { const char* key; double fx, fy, cx, cy; };
  for (const Camera& c : {Camera{"freiburg1", 517.3, 516.5, 318.6, 255.3}, Camera{"freiburg2", 520.9, 521.0, 325.1, 249.7},
                          Camera{"freiburg3", 535.4, 539.2, 320.1, 247.6}}) {
    if (name.find(c.key) == std::string::npos) continue;
    k->fx = c.fx, k->fy = c.fy, k->cx = c.cx, k->cy = c.cy;
    *source = fmt::format("the TUM RGB-D {} calibration (from the folder's name)", c.key);
    return true;
  }
  return false;
}

}  // namespace

DepthRecording read_tum_recording(const std::string& folder, const RecordingOptions& options) {
  DepthRecording r;
  const std::string list = (fs::path(folder) / "depth.txt").string();
  std::ifstream in(list);
  if (!in) throw InputError(fmt::format("{}: cannot be read; a TUM RGB-D recording lists its depth frames there", list));
  std::string line;
  int line_number = 0;
  while (std::getline(in, line)) {
    ++line_number;
    const size_t start = line.find_first_not_of(" \t\r");
    if (start == std::string::npos || line[start] == '#') continue;
    std::stringstream fields(line);
    double t = 0;
    std::string name, rest;
    if (!(fields >> t >> name) || (fields >> rest))
      throw InputError(fmt::format("{}: line {} '{}' is not 'timestamp filename' (a time in seconds and a PNG path)",
                                   list, line_number, line));
    const fs::path file = fs::path(folder) / name;
    if (!fs::is_regular_file(file))
      throw InputError(fmt::format("{}: line {} names {}, which does not exist: a frame is missing; restore it or "
                                   "delete its line (the timestamps then keep the gap)", list, line_number,
                                   file.string()));
    if (!r.timestamps.empty() && !(t > r.timestamps.back()))
      throw InputError(fmt::format("{}: line {}: timestamp {} does not follow {}; the frames must be listed in time "
                                   "order, each once", list, line_number, t, r.timestamps.back()));
    r.timestamps.push_back(t);
    r.files.push_back(file.string());
  }
  if (r.files.empty()) throw InputError(fmt::format("{}: lists no depth frame", list));
  if (!options.intrinsics.empty()) {
    r.intrinsics = parse_intrinsics_option(options.intrinsics, &r.intrinsics_source);
  } else if (const std::string file = find_intrinsics_json(folder); !file.empty()) {
    r.intrinsics = read_intrinsics_json(file);
    r.intrinsics_source = file;
  } else if (published_tum_intrinsics(folder, &r.intrinsics, &r.intrinsics_source)) {
    note(fmt::format("{}: intrinsics from {}", folder, r.intrinsics_source));
  } else {
    throw InputError(fmt::format("{}: the intrinsics are missing: a TUM recording has no intrinsics file; give "
                                 "--intrinsics fx,fy,cx,cy (the TUM Kinects: freiburg1 517.3,516.5,318.6,255.3; "
                                 "freiburg2 520.9,521.0,325.1,249.7; freiburg3 535.4,539.2,320.1,247.6)", folder));
  }
  r.depth_scale = depth_scale_option(options, 1.0 / 5000);
  if (options.fps) note("--fps is not used: a TUM recording has its own timestamps (depth.txt)");
  select_frames(options, &r.files, &r.timestamps, list);
  return r;
}

}  // namespace ssc
