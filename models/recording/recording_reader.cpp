// What the recording readers share (recording_readers.h) and the format detection.
#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <sstream>

#include "models/io/json_reader.h"
#include "models/io/run_record.h"
#include "models/recording/recording_readers.h"
#include "runtime/errors.h"

namespace fs = std::filesystem;

namespace ssc {

namespace {

bool natural_less(const std::string& a, const std::string& b) {
  size_t i = 0, j = 0;
  while (i < a.size() && j < b.size()) {
    if (std::isdigit((unsigned char)a[i]) && std::isdigit((unsigned char)b[j])) {
      size_t ie = i, je = j;
      while (ie < a.size() && std::isdigit((unsigned char)a[ie])) ++ie;
      while (je < b.size() && std::isdigit((unsigned char)b[je])) ++je;
      const std::string na = a.substr(i, ie - i), nb = b.substr(j, je - j);
      const std::string ta = na.substr(std::min(na.find_first_not_of('0'), na.size()));
      const std::string tb = nb.substr(std::min(nb.find_first_not_of('0'), nb.size()));
      if (ta.size() != tb.size()) return ta.size() < tb.size();
      if (ta != tb) return ta < tb;
      i = ie, j = je;
    } else {
      if (a[i] != b[j]) return a[i] < b[j];
      ++i, ++j;
    }
  }
  return a.size() - i < b.size() - j;
}

bool ends_with_png(const std::string& name) {
  if (name.size() < 4) return false;
  std::string ext = name.substr(name.size() - 4);
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  return ext == ".png";
}

}  // namespace

std::string find_intrinsics_json(const std::string& folder) {
  for (const char* name : {"intrinsic.json", "camera_intrinsic.json"}) {
    const fs::path p = fs::path(folder) / name;
    if (fs::is_regular_file(p)) return p.string();
  }
  return "";
}

void take_intrinsics(DepthRecording& r, const RecordingOptions& options, const std::string& folder,
                     const std::string& missing) {
  if (!options.intrinsics.empty()) {
    r.intrinsics = parse_intrinsics_option(options.intrinsics, &r.intrinsics_source);
    return;
  }
  const std::string file = find_intrinsics_json(folder);
  if (file.empty()) throw InputError(missing);
  r.intrinsics = read_intrinsics_json(file);
  r.intrinsics_source = file;
}

std::vector<std::string> list_png_files(const std::string& folder) {
  std::vector<std::string> names;
  for (const auto& e : fs::directory_iterator(folder))
    if (e.is_regular_file() && ends_with_png(e.path().filename().string())) names.push_back(e.path().filename().string());
  std::sort(names.begin(), names.end(), natural_less);
  std::vector<std::string> files;
  for (const std::string& n : names) files.push_back((fs::path(folder) / n).string());
  return files;
}

DepthIntrinsics read_intrinsics_json(const std::string& file) {
  const nlohmann::json j = read_json_file(file);
  const JsonReader r(j, file, "");
  DepthIntrinsics k;
  k.width = r.integer("width");
  k.height = r.integer("height");
  r.require(k.width > 0, "width", "must be a positive number of pixels");
  r.require(k.height > 0, "height", "must be a positive number of pixels");
  const std::vector<double> m = r.numbers("intrinsic_matrix");
  r.require(m.size() == 9, "intrinsic_matrix",
            fmt::format("must hold the 9 numbers of the 3x3 camera matrix in column-major order "
                        "[fx, 0, 0, 0, fy, 0, cx, cy, 1], found {}", m.size()));
  r.require(m[8] == 1 && m[2] == 0 && m[5] == 0, "intrinsic_matrix",
            "must be column-major [fx, 0, 0, 0, fy, 0, cx, cy, 1] (its last row 0 0 1 is at entries 2, 5, 8); a "
            "row-major matrix [fx, 0, cx, 0, fy, cy, 0, 0, 1] must be transposed");
  k.fx = m[0];
  k.fy = m[4];
  k.cx = m[6];
  k.cy = m[7];
  return k;
}

DepthIntrinsics parse_intrinsics_option(const std::string& text, std::string* source) {
  if (fs::exists(text)) {
    *source = text;
    return read_intrinsics_json(text);
  }
  std::vector<double> v;
  std::stringstream in(text);
  std::string item;
  while (std::getline(in, item, ',')) {
    try {
      size_t used = 0;
      v.push_back(std::stod(item, &used));
      if (used != item.size()) v.push_back(NAN);
    } catch (const std::exception&) {
      v.push_back(NAN);
    }
  }
  const bool ok = v.size() == 4 && std::all_of(v.begin(), v.end(), [](double x) { return std::isfinite(x); });
  if (!ok)
    throw InputError(fmt::format("--intrinsics '{}': give fx,fy,cx,cy in pixels (e.g. 525,525,319.5,239.5) or an "
                                 "existing JSON file with width, height and a column-major intrinsic_matrix",
                                 text));
  *source = "--intrinsics";
  DepthIntrinsics k;
  k.fx = v[0], k.fy = v[1], k.cx = v[2], k.cy = v[3];
  return k;
}

void select_frames(const RecordingOptions& o, std::vector<std::string>* files, std::vector<double>* timestamps,
                   const std::string& where) {
  const int n = int(files->size());
  const int end = o.end_frame < 0 ? n : o.end_frame;
  if (o.first_frame < 0 || o.first_frame >= end || end > n)
    throw InputError(fmt::format("--frames {}:{}: {} holds frames 0..{}; give A:B with 0 <= A < B <= {}", o.first_frame,
                                 o.end_frame < 0 ? std::string() : std::to_string(o.end_frame), where, n - 1, n));
  files->assign(files->begin() + o.first_frame, files->begin() + end);
  timestamps->assign(timestamps->begin() + o.first_frame, timestamps->begin() + end);
}

void parse_frame_range(const std::string& text, RecordingOptions* o) {
  const size_t colon = text.find(':');
  auto number = [&](const std::string& s, int fallback) {
    if (s.empty()) return fallback;
    size_t used = 0;
    int value = -2;
    try {
      value = std::stoi(s, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (used != s.size() || value < 0)
      throw InputError(fmt::format("--frames '{}': give A:B, frame numbers >= 0 (B excluded; either may be left "
                                   "out, e.g. 0:60 or 10:)", text));
    return value;
  };
  if (colon == std::string::npos)
    throw InputError(fmt::format("--frames '{}': give A:B (frames A to B-1, e.g. 0:60)", text));
  o->first_frame = number(text.substr(0, colon), 0);
  o->end_frame = number(text.substr(colon + 1), -1);
}

std::vector<double> timestamps_from_fps(const RecordingOptions& o, size_t frames, const std::string& format) {
  if (!o.fps)
    throw InputError(fmt::format("{} has no timestamps: give the frame rate with --fps (e.g. --fps 30)",
                                 format));
  if (!(*o.fps > 0) || !std::isfinite(*o.fps))
    throw InputError(fmt::format("--fps {}: must be a positive number of frames per second", *o.fps));
  std::vector<double> t(frames);
  for (size_t f = 0; f < frames; ++f) t[f] = double(f) / *o.fps;
  return t;
}

std::vector<double> timestamps_from_numbered_files(const RecordingOptions& o, const std::vector<std::string>& files,
                                                   const std::string& format) {
  std::vector<double> t = timestamps_from_fps(o, files.size(), format);
  std::vector<long> numbers;
  for (const std::string& file : files) {
    const std::string name = fs::path(file).stem().string();
    const size_t end = name.find_last_of("0123456789");
    if (end == std::string::npos) return t;
    size_t begin = end;
    while (begin > 0 && std::isdigit((unsigned char)name[begin - 1])) --begin;
    if (end - begin > 15) return t;  // a timestamp in nanoseconds, not a frame number
    numbers.push_back(std::stol(name.substr(begin, end - begin + 1)));
  }
  int dropped = 0;
  for (size_t f = 0; f < files.size(); ++f) {
    if (f > 0 && numbers[f] <= numbers[f - 1])
      throw InputError(fmt::format("{}: its frame number {} does not follow {} ({}); name the frames with increasing "
                                   "numbers", files[f], numbers[f], files[f - 1], numbers[f - 1]));
    if (f > 0) dropped += int(numbers[f] - numbers[f - 1] - 1);
    t[f] = double(numbers[f] - numbers[0]) / *o.fps;
  }
  if (dropped > 0)
    warn("dropped_frames", fmt::format("{}: {} frame numbers are missing between {} and {}: taken as dropped frames, "
                                       "gaps in the frame times (frame_times in cameras.json)",
                                       fs::path(files.front()).parent_path().string(), dropped, files.front(),
                                       files.back()));
  return t;
}

double depth_scale_option(const RecordingOptions& o, double fallback) {
  if (!o.depth_scale) return fallback;
  const double s = *o.depth_scale;
  if (!(s > 0) || !std::isfinite(s))
    throw InputError(fmt::format("--depth-scale {}: must be a positive number of metres per PNG unit (0.001 for "
                                 "millimetres, 0.0002 for TUM's 5000 per metre)", s));
  if (s > 1)
    throw InputError(fmt::format("--depth-scale {}: is metres per PNG unit, so {} would make one unit {} m; a scale "
                                 "in units per metre (Open3D's depth_scale {}) is given as its inverse, --depth-scale {}",
                                 s, s, s, s, 1 / s));
  return s;
}

void load_frames(DepthRecording* r) {
  if (r->files.empty()) throw InputError(fmt::format("{}: the recording holds no depth frame", r->folder));
  r->frames.clear();
  for (const std::string& file : r->files) {
    r->frames.push_back(read_depth_png(file, r->depth_scale));
    const DepthImage& img = r->frames.back();
    const DepthImage& first = r->frames.front();
    if (img.width != first.width || img.height != first.height)
      throw InputError(fmt::format("{}: is {}x{} pixels, but {} is {}x{}; every depth frame of a recording must have "
                                   "the same size", file, img.width, img.height, r->files.front(), first.width,
                                   first.height));
  }
  DepthIntrinsics& k = r->intrinsics;
  const DepthImage& img = r->frames.front();
  if (k.width == 0) k.width = img.width;
  if (k.height == 0) k.height = img.height;
  const std::string& src = r->intrinsics_source;
  if (k.width != img.width || k.height != img.height)
    throw InputError(fmt::format("{}: the intrinsics are for {}x{} images, but the depth frames ({}) are {}x{}; give "
                                 "the depth stream's own intrinsics (scale fx, fy, cx, cy with the image if it was "
                                 "resized)", src, k.width, k.height, r->files.front(), img.width, img.height));
  if (!(k.fx > 0) || !(k.fy > 0) || !std::isfinite(k.fx) || !std::isfinite(k.fy))
    throw InputError(fmt::format("{}: focal lengths fx = {}, fy = {} must be positive numbers of pixels", src, k.fx, k.fy));
  // A principal point far from the centre means intrinsics of another resolution (or swapped values).
  const double off_x = std::abs(k.cx - (img.width - 1) / 2.0) / img.width;
  const double off_y = std::abs(k.cy - (img.height - 1) / 2.0) / img.height;
  if (!std::isfinite(k.cx) || !std::isfinite(k.cy) || off_x > 0.25 || off_y > 0.25)
    throw InputError(fmt::format("{}: the principal point (cx, cy) = ({}, {}) is far from the centre ({}, {}) of the "
                                 "{}x{} depth images; these intrinsics are not for images of this size (or cx, cy are "
                                 "swapped): give the depth stream's intrinsics at this resolution",
                                 src, k.cx, k.cy, (img.width - 1) / 2.0, (img.height - 1) / 2.0, img.width, img.height));
  const double fov_x = 2 * std::atan(img.width / (2 * k.fx)) * 180 / M_PI;
  if (fov_x < 10 || fov_x > 150)
    throw InputError(fmt::format("{}: fx = {} px gives a horizontal field of view of {:.0f} degrees for {} px wide "
                                 "images; depth cameras have 50-120: these intrinsics are not for images of this size",
                                 src, k.fx, fov_x, img.width));
}

std::string detect_recording_format(const std::string& folder) {
  if (!fs::is_directory(folder))
    throw InputError(fmt::format("{}: is not a folder; give the recording's folder (Open3D: depth/ and "
                                 "intrinsic.json; TUM: depth.txt; or a folder of 16-bit depth PNGs)", folder));
  if (fs::is_regular_file(fs::path(folder) / "depth.txt")) return "tum";
  if (fs::is_directory(fs::path(folder) / "depth") && !find_intrinsics_json(folder).empty()) return "open3d";
  if (!list_png_files(folder).empty()) return "folder";
  throw InputError(fmt::format("{}: not a recording ssc knows: no depth.txt (TUM RGB-D), no depth/ folder with "
                               "intrinsic.json (Open3D), no PNG files (a plain folder); give --format and the "
                               "recording's own folder", folder));
}

DepthRecording read_recording(const std::string& folder, const RecordingOptions& options) {
  const std::string format = options.format == "auto" ? detect_recording_format(folder) : options.format;
  if (!fs::is_directory(folder)) detect_recording_format(folder);  // its message for a missing folder
  DepthRecording r;
  if (format == "open3d") r = read_open3d_recording(folder, options);
  else if (format == "tum") r = read_tum_recording(folder, options);
  else if (format == "folder") r = read_folder_recording(folder, options);
  else
    throw InputError(fmt::format("--format {}: give auto, open3d, tum or folder", options.format));
  r.format = format;
  r.folder = folder;
  load_frames(&r);
  return r;
}

}  // namespace ssc
