// Reading, checking and writing observation folders (see observation_set.h and
// docs/observation-format.md). The reader is deliberately pedantic: a real recording is
// converted by hand-written scripts, and every mistake it can make (a key spelled wrong,
// millimetres instead of metres, a missing frame) should be reported with the file and the
// fix instead of surfacing later as a bad reconstruction. The writer validates with the
// same rules, so whatever it writes reads back.
#include "models/observation/observation_set.h"

#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fmt/format.h>

#include <algorithm>
#include <fstream>
#include <limits>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>

#include "runtime/errors.h"
#include "models/io/text_file.h"
#include "models/io/output_dir.h"
#include "models/io/run_record.h"

namespace ssc {

namespace fs = std::filesystem;
using Json = nlohmann::json;

namespace {

constexpr const char* kDocs = "see docs/observation-format.md";

// ---- depth_pattern -------------------------------------------------------------------

struct Pattern {
  std::string prefix, suffix;
  int width = 0;
  bool zero_pad = false;
};

[[noreturn]] void bad_pattern(const std::string& pattern, const std::string& where, const std::string& why) {
  throw InputError(fmt::format("{}: depth_pattern '{}' {}; use a relative path with exactly one frame "
                               "number conversion, e.g. \"cam0/depth_%04d.png\"", where, pattern, why));
}

// Parses the single %[0][width]d conversion at pattern[i] (pattern[i] == '%'); returns the
// index after it.
std::size_t parse_conversion(const std::string& p, std::size_t i, Pattern* out, const std::string& where) {
  std::size_t j = i + 1;
  if (j < p.size() && p[j] == '0') {
    out->zero_pad = true;
    ++j;
  }
  int width = 0;
  while (j < p.size() && p[j] >= '0' && p[j] <= '9') {
    width = 10 * width + (p[j] - '0');
    if (width > 9) bad_pattern(p, where, "has a field width above 9");
    ++j;
  }
  if (j >= p.size() || p[j] != 'd') bad_pattern(p, where, "has a % that is not %d, %0Nd or %%");
  out->width = width;
  return j + 1;
}

Pattern parse_pattern(const std::string& p, const std::string& where) {
  Pattern out;
  int conversions = 0;
  for (std::size_t i = 0; i < p.size();) {
    if (p[i] != '%') {
      (conversions ? out.suffix : out.prefix) += p[i++];
    } else if (i + 1 < p.size() && p[i + 1] == '%') {
      (conversions ? out.suffix : out.prefix) += '%';
      i += 2;
    } else {
      if (++conversions > 1) bad_pattern(p, where, "has more than one conversion");
      i = parse_conversion(p, i, &out, where);
    }
  }
  if (conversions != 1) bad_pattern(p, where, "has no frame number conversion (%d)");
  return out;
}

void check_pattern_path(const std::string& pattern, const std::string& where) {
  const fs::path path(pattern);
  if (path.is_absolute()) bad_pattern(pattern, where, "is an absolute path (it must lie inside the folder)");
  for (const fs::path& part : path)
    if (part == "..") bad_pattern(pattern, where, "leaves the folder with '..'");
}

// ---- shared checks -------------------------------------------------------------------

std::string camera_label(const ObservationSet& set, std::size_t i) {
  return fmt::format("camera {} ('{}')", i, set.cameras[i].name);
}

// Every depth must be 0 or within the camera's range, widened by `tolerance` (half a PNG
// unit when reading, because quantisation may move a boundary depth by that much).
void check_depth_values(const DepthImage& image, const DepthCamera& cam, double tolerance,
                        const std::string& image_where, const std::string& camera_where) {
  long bad = 0, first = -1;
  for (std::size_t k = 0; k < image.depth.size(); ++k) {
    const double d = image.depth[k];
    if (d == 0) continue;
    if (std::isfinite(d) && d >= cam.min_depth - tolerance && d <= cam.max_depth + tolerance) continue;
    if (bad++ == 0) first = long(k);
  }
  if (bad == 0) return;
  throw InputError(fmt::format(
      "{}: {} pixel(s) have a depth outside [{}, {}] m, the depth range of camera '{}' (first at u={}, "
      "v={}: {} m); set such pixels to 0 (no measurement), or fix min_depth/max_depth of {}, or check "
      "depth_scale (metres per PNG unit)",
      image_where, bad, cam.min_depth, cam.max_depth, cam.name, first % image.width, first / image.width,
      image.depth[first], camera_where));
}

void check_image_size(const DepthImage& image, const DepthCamera& cam, const std::string& image_where,
                      const std::string& camera_where) {
  if (image.width == cam.width && image.height == cam.height &&
      image.depth.size() == std::size_t(image.width) * image.height)
    return;
  throw InputError(fmt::format("{}: the depth image is {}x{} but {} ('{}') says {}x{}; make width and "
                               "height in cameras.json match the depth images",
                               image_where, image.width, image.height, camera_where, cam.name, cam.width,
                               cam.height));
}

void check_scalars(double dt, double depth_scale, double first_frame_time, int frame_count,
                   std::size_t cameras, const std::string& where) {
  if (!(dt > 0) || !std::isfinite(dt))
    throw InputError(fmt::format("{}: dt = {} must be a positive number of seconds between frames", where, dt));
  if (!(depth_scale > 0) || !std::isfinite(depth_scale))
    throw InputError(fmt::format("{}: depth_scale = {} must be a positive number of metres per PNG unit "
                                 "(0.001 for millimetre PNGs)", where, depth_scale));
  if (!std::isfinite(first_frame_time))
    throw InputError(fmt::format("{}: first_frame_time must be a finite number of seconds", where));
  if (frame_count < 1)
    throw InputError(fmt::format("{}: frame_count = {} must be at least 1", where, frame_count));
  if (cameras == 0) throw InputError(fmt::format("{}: the set has no cameras; list at least one", where));
}

// How far the median interval of frame_times may be from dt (either way): enough for a
// recording that lost every other frame, far too little for milliseconds or frame numbers.
constexpr double kFrameIntervalFactor = 2.5;

// frame_times: one per frame, finite, strictly increasing, starting at first_frame_time and
// spaced about dt apart.
void check_frame_times(const ObservationSet& set, const std::string& where) {
  const std::vector<double>& t = set.frame_times;
  if (t.empty()) return;
  if (t.size() != std::size_t(set.frame_count))
    throw InputError(fmt::format("{}: frame_times has {} entries but frame_count = {}; give one time (seconds) per "
                                 "frame, in the order of the frame files", where, t.size(), set.frame_count));
  for (std::size_t i = 0; i < t.size(); ++i) {
    if (!std::isfinite(t[i]))
      throw InputError(fmt::format("{}: frame_times[{}] is not a finite number of seconds", where, i));
    if (i > 0 && !(t[i] > t[i - 1]))
      throw InputError(fmt::format("{}: frame_times[{}] = {} s is not after frame_times[{}] = {} s; the times must "
                                   "increase strictly (one per frame file, in file order)",
                                   where, i, t[i], i - 1, t[i - 1]));
  }
  if (std::abs(set.first_frame_time - t[0]) > 1e-9 * std::max(1.0, std::abs(t[0])))
    throw InputError(fmt::format("{}: first_frame_time = {} s but frame_times[0] = {} s; leave first_frame_time out "
                                 "or make it frame_times[0]", where, set.first_frame_time, t[0]));
  if (t.size() < 2) return;
  std::vector<double> intervals;
  for (std::size_t i = 1; i < t.size(); ++i) intervals.push_back(t[i] - t[i - 1]);
  std::nth_element(intervals.begin(), intervals.begin() + intervals.size() / 2, intervals.end());
  const double median = intervals[intervals.size() / 2];
  if (median > kFrameIntervalFactor * set.dt || median < set.dt / kFrameIntervalFactor)
    throw InputError(fmt::format("{}: the frame_times are {} s apart (median) but dt = {} s; give frame_times in "
                                 "seconds (not milliseconds or frame numbers) and dt = 1 / frame rate",
                                 where, median, set.dt));
}

// Cameras and patterns; the file names of all frames must be distinct across cameras.
void check_cameras(const std::vector<DepthCamera>& cameras, const std::vector<std::string>& patterns,
                   int frame_count, const std::string& where) {
  if (patterns.size() != cameras.size())
    throw InputError(fmt::format("{}: {} depth patterns for {} cameras; give one per camera", where,
                                 patterns.size(), cameras.size()));
  std::set<std::string> names;
  for (std::size_t i = 0; i < cameras.size(); ++i) {
    const std::string cam_where = fmt::format("{}: cameras[{}]", where, i);
    validate_camera(cameras[i], cam_where);
    check_pattern_path(patterns[i], cam_where);
    for (int f = 0; f < frame_count; ++f)
      if (!names.insert(depth_file_name(patterns[i], f, cam_where)).second)
        throw InputError(fmt::format("{}: depth_pattern '{}' gives file '{}' (frame {}) that another camera "
                                     "or frame uses too; give every camera its own pattern",
                                     cam_where, patterns[i], depth_file_name(patterns[i], f), f));
  }
}

void check_depth_noise(const DepthNoise& n, const std::string& where) {
  if (!(n.sigma0_m >= 0) || !std::isfinite(n.sigma0_m) || !(n.per_m2 >= 0) || !std::isfinite(n.per_m2))
    throw InputError(fmt::format("{}: depth_noise sigma0_m = {} m and per_m2 = {} 1/m must be finite and >= 0 "
                                 "(sigma(z) = sigma0_m + per_m2 z^2, metres); {}",
                                 where, n.sigma0_m, n.per_m2, kDocs));
}

void validate_with_patterns(const ObservationSet& set, const std::vector<std::string>& patterns,
                            const std::string& where) {
  check_scalars(set.dt, set.depth_scale, set.first_frame_time, set.frame_count, set.cameras.size(), where);
  check_frame_times(set, where);
  check_cameras(set.cameras, patterns, set.frame_count, where);
  if (!set.depth_noise.empty() && set.depth_noise.size() != set.cameras.size())
    throw InputError(fmt::format("{}: {} depth noise models for {} cameras; give one per camera or none", where,
                                 set.depth_noise.size(), set.cameras.size()));
  for (std::size_t i = 0; i < set.depth_noise.size(); ++i)
    if (set.depth_noise[i]) check_depth_noise(*set.depth_noise[i], fmt::format("{}: cameras[{}]", where, i));
  if (set.frames.size() != std::size_t(set.frame_count))
    throw InputError(fmt::format("{}: frame_count = {} but {} frames are given", where, set.frame_count,
                                 set.frames.size()));
  for (int f = 0; f < set.frame_count; ++f) {
    if (set.frames[f].size() != set.cameras.size())
      throw InputError(fmt::format("{}: frame {} has {} images for {} cameras", where, f,
                                   set.frames[f].size(), set.cameras.size()));
    for (std::size_t i = 0; i < set.cameras.size(); ++i) {
      const std::string image_where = fmt::format("{}: frame {} of {}", where, f, camera_label(set, i));
      const std::string cam_where = fmt::format("cameras[{}]", i);
      check_image_size(set.frames[f][i], set.cameras[i], image_where, cam_where);
      check_depth_values(set.frames[f][i], set.cameras[i], 0.0, image_where, cam_where);
    }
  }
}

std::vector<std::string> patterns_or_default(const ObservationSet& set) {
  if (!set.depth_patterns.empty()) return set.depth_patterns;
  std::vector<std::string> patterns;
  for (std::size_t i = 0; i < set.cameras.size(); ++i) patterns.push_back(default_depth_pattern(int(i)));
  return patterns;
}

// ---- writing -------------------------------------------------------------------------

nlohmann::ordered_json depth_noise_json(const DepthNoise& n) {
  return nlohmann::ordered_json{
      {"sigma0_m", n.sigma0_m}, {"per_m2", n.per_m2}, {"along", n.along_ray ? "ray" : "depth"}};
}

nlohmann::ordered_json camera_json(const DepthCamera& cam, const std::string& pattern) {
  nlohmann::ordered_json pose = nlohmann::ordered_json::array();
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) pose.push_back(cam.camera_to_world(r, c));
  return nlohmann::ordered_json{{"name", cam.name},           {"width", cam.width},
                                {"height", cam.height},       {"fx", cam.fx},
                                {"fy", cam.fy},               {"cx", cam.cx},
                                {"cy", cam.cy},               {"camera_to_world", pose},
                                {"min_depth", cam.min_depth}, {"max_depth", cam.max_depth},
                                {"depth_pattern", pattern}};
}

// One model for every camera: at the top level; otherwise in each camera that has one.
bool shared_depth_noise(const ObservationSet& set) {
  if (set.depth_noise.empty() || !set.depth_noise[0]) return false;
  for (const std::optional<DepthNoise>& n : set.depth_noise)
    if (!n || !(*n == *set.depth_noise[0])) return false;
  return true;
}

void write_header(const fs::path& folder, const ObservationSet& set, const std::vector<std::string>& patterns) {
  nlohmann::ordered_json j;
  j["format"] = kObservationFormat;
  j["dt"] = set.dt;
  j["depth_scale"] = set.depth_scale;
  j["frame_count"] = set.frame_count;
  j["first_frame_time"] = set.first_frame_time;
  if (!set.frame_times.empty()) j["frame_times"] = set.frame_times;
  const bool shared = shared_depth_noise(set);
  if (shared) j["depth_noise"] = depth_noise_json(*set.depth_noise[0]);
  j["cameras"] = nlohmann::ordered_json::array();
  for (std::size_t i = 0; i < set.cameras.size(); ++i) {
    j["cameras"].push_back(camera_json(set.cameras[i], patterns[i]));
    if (!shared && i < set.depth_noise.size() && set.depth_noise[i])
      j["cameras"].back()["depth_noise"] = depth_noise_json(*set.depth_noise[i]);
  }
  write_text_file((folder / "cameras.json").string(), j.dump(2) + "\n");
}

void write_frames(const fs::path& folder, const ObservationSet& set, const std::vector<std::string>& patterns) {
  for (int f = 0; f < set.frame_count; ++f)
    for (std::size_t i = 0; i < set.cameras.size(); ++i) {
      const fs::path relative = fs::path(depth_file_name(patterns[i], f));
      if (relative.has_parent_path()) create_folders_below(folder.string(), relative.parent_path().string());
      write_depth_png((folder / relative).string(), set.frames[f][i], set.depth_scale);
    }
}

// ---- reading -------------------------------------------------------------------------

std::string qualified(const std::string& ctx, const std::string& key) {
  return ctx.empty() ? key : ctx + "." + key;
}

const Json& get_key(const Json& obj, const std::string& key, const std::string& file, const std::string& ctx) {
  if (!obj.is_object())
    throw InputError(fmt::format("{}: '{}' must be a JSON object, got {}; {}", file, ctx.empty() ? "top level" : ctx,
                                 obj.type_name(), kDocs));
  const auto it = obj.find(key);
  if (it == obj.end())
    throw InputError(fmt::format("{}: missing key '{}'; {}", file, qualified(ctx, key), kDocs));
  return *it;
}

double as_number(const Json& v, const std::string& file, const std::string& name) {
  if (!v.is_number())
    throw InputError(fmt::format("{}: key '{}' must be a number, got {} ({}); {}", file, name, v.type_name(),
                                 v.dump(), kDocs));
  const double x = v.get<double>();
  if (!std::isfinite(x)) throw InputError(fmt::format("{}: key '{}' is not a finite number", file, name));
  return x;
}

double get_number(const Json& obj, const std::string& key, const std::string& file, const std::string& ctx) {
  return as_number(get_key(obj, key, file, ctx), file, qualified(ctx, key));
}

int get_int(const Json& obj, const std::string& key, const std::string& file, const std::string& ctx) {
  const double x = get_number(obj, key, file, ctx);
  if (x != std::floor(x) || std::fabs(x) > std::numeric_limits<int>::max())
    throw InputError(fmt::format("{}: key '{}' must be an integer, got {}", file, qualified(ctx, key), x));
  return int(x);
}

std::string get_string(const Json& obj, const std::string& key, const std::string& file, const std::string& ctx) {
  const Json& v = get_key(obj, key, file, ctx);
  if (!v.is_string())
    throw InputError(fmt::format("{}: key '{}' must be a string, got {} ({}); {}", file, qualified(ctx, key),
                                 v.type_name(), v.dump(), kDocs));
  return v.get<std::string>();
}

Eigen::Matrix4d get_pose(const Json& obj, const std::string& file, const std::string& ctx) {
  const std::string key = "camera_to_world";  // a named key: no temporary for the reference to outlive
  const Json& v = get_key(obj, key, file, ctx);
  const std::string name = qualified(ctx, key);
  if (!v.is_array() || v.size() != 16)
    throw InputError(fmt::format("{}: key '{}' must be an array of 16 numbers (row-major 4x4 camera-to-world "
                                 "pose), got {}", file, name, v.dump()));
  Eigen::Matrix4d m;
  for (int k = 0; k < 16; ++k) m(k / 4, k % 4) = as_number(v[k], file, fmt::format("{}[{}]", name, k));
  return m;
}

DepthCamera parse_camera(const Json& j, const std::string& file, const std::string& ctx) {
  DepthCamera cam;
  cam.name = get_string(j, "name", file, ctx);
  cam.width = get_int(j, "width", file, ctx);
  cam.height = get_int(j, "height", file, ctx);
  cam.fx = get_number(j, "fx", file, ctx);
  cam.fy = get_number(j, "fy", file, ctx);
  cam.cx = get_number(j, "cx", file, ctx);
  cam.cy = get_number(j, "cy", file, ctx);
  cam.camera_to_world = get_pose(j, file, ctx);
  cam.min_depth = get_number(j, "min_depth", file, ctx);
  cam.max_depth = get_number(j, "max_depth", file, ctx);
  return cam;
}

Json parse_json_file(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(fmt::format("{}: cannot open the file", path.string()));
  std::stringstream text;
  text << in.rdbuf();
  try {
    return Json::parse(text.str());
  } catch (const Json::parse_error& e) {
    throw InputError(fmt::format("{}: malformed JSON ({}); fix the syntax", path.string(), e.what()));
  }
}

void check_format(const Json& j, const std::string& file) {
  const std::string format = get_string(j, "format", file, "");
  if (format != kObservationFormat)
    throw InputError(fmt::format("{}: unknown format '{}'; this reader understands \"format\": \"{}\"", file,
                                 format, kObservationFormat));
}

// A key the reader does not know is most likely a typo of an optional one: say so.
void warn_unknown_keys(const Json& j, const std::vector<std::string>& known, const std::string& file, const std::string& ctx) {
  if (!j.is_object()) return;
  std::string list;
  for (const std::string& k : known) list += (list.empty() ? "" : ", ") + k;
  for (auto it = j.begin(); it != j.end(); ++it)
    if (std::find(known.begin(), known.end(), it.key()) == known.end())
      warn("unknown_key", fmt::format("{}: unknown key '{}' is ignored (a typo?); the keys here are: {}", file,
                                      qualified(ctx, it.key()), list));
}

DepthNoise parse_depth_noise(const Json& j, const std::string& file, const std::string& ctx) {
  if (!j.is_object())
    throw InputError(fmt::format("{}: '{}' must be an object {{\"sigma0_m\": ..., \"per_m2\": ..., \"along\": "
                                 "\"depth\"}}, got {}; {}",
                                 file, ctx, j.dump(), kDocs));
  warn_unknown_keys(j, {"sigma0_m", "per_m2", "along"}, file, ctx);
  DepthNoise n;
  n.sigma0_m = j.contains("sigma0_m") ? get_number(j, "sigma0_m", file, ctx) : 0.0;
  n.per_m2 = j.contains("per_m2") ? get_number(j, "per_m2", file, ctx) : 0.0;
  const std::string along = j.contains("along") ? get_string(j, "along", file, ctx) : "depth";
  if (along != "depth" && along != "ray")
    throw InputError(fmt::format("{}: '{}.along' is '{}'; use \"depth\" (noise of the stored z depth) or \"ray\" "
                                 "(noise of the distance along the viewing ray)",
                                 file, ctx, along));
  n.along_ray = along == "ray";
  check_depth_noise(n, fmt::format("{}: {}", file, ctx));
  return n;
}

// Everything of cameras.json; the images are read by read_frames.
ObservationSet parse_header(const Json& j, const std::string& file) {
  check_format(j, file);
  warn_unknown_keys(j, {"format", "dt", "depth_scale", "frame_count", "first_frame_time", "frame_times", "depth_noise",
                       "cameras"}, file, "");
  ObservationSet set;
  set.dt = get_number(j, "dt", file, "");
  set.depth_scale = get_number(j, "depth_scale", file, "");
  set.frame_count = get_int(j, "frame_count", file, "");
  if (j.contains("frame_times")) {
    const Json& times = j["frame_times"];
    if (!times.is_array() || times.empty())
      throw InputError(fmt::format("{}: key 'frame_times' must be an array of times in seconds, one per frame, got {}",
                                   file, times.dump()));
    for (std::size_t f = 0; f < times.size(); ++f)
      set.frame_times.push_back(as_number(times[f], file, fmt::format("frame_times[{}]", f)));
  }
  set.first_frame_time = j.contains("first_frame_time") ? get_number(j, "first_frame_time", file, "")
                         : set.frame_times.empty()      ? 0.0
                                                        : set.frame_times[0];
  std::optional<DepthNoise> shared_noise;
  if (j.contains("depth_noise")) shared_noise = parse_depth_noise(j["depth_noise"], file, "depth_noise");
  const std::string cameras_key = "cameras", top = "";  // named: no temporary for the reference to outlive
  const Json& cams = get_key(j, cameras_key, file, top);
  if (!cams.is_array()) throw InputError(fmt::format("{}: key 'cameras' must be an array of cameras", file));
  bool any_noise = bool(shared_noise);
  for (std::size_t i = 0; i < cams.size(); ++i) {
    const std::string ctx = fmt::format("cameras[{}]", i);
    set.cameras.push_back(parse_camera(cams[i], file, ctx));
    set.depth_patterns.push_back(get_string(cams[i], "depth_pattern", file, ctx));
    warn_unknown_keys(cams[i], {"name", "width", "height", "fx", "fy", "cx", "cy", "camera_to_world", "min_depth",
                                "max_depth", "depth_pattern", "depth_noise"}, file, ctx);
    set.depth_noise.push_back(cams[i].contains("depth_noise")
                                  ? parse_depth_noise(cams[i]["depth_noise"], file, ctx + ".depth_noise")
                                  : shared_noise);
    any_noise |= bool(set.depth_noise.back());
  }
  if (!any_noise) set.depth_noise.clear();
  check_scalars(set.dt, set.depth_scale, set.first_frame_time, set.frame_count, set.cameras.size(), file);
  check_frame_times(set, file);
  check_cameras(set.cameras, set.depth_patterns, set.frame_count, file);
  return set;
}

DepthImage read_frame(const ObservationSet& set, const fs::path& folder, int f, std::size_t i,
                      const std::string& json_file) {
  const fs::path png = folder / depth_file_name(set.depth_patterns[i], f);
  std::error_code ec;
  if (!fs::exists(png, ec)) {
    int later = -1;  // a later frame of this camera that is there: f is a gap, not the end
    for (int g = f + 1; g < set.frame_count && later < 0; ++g)
      if (fs::exists(folder / depth_file_name(set.depth_patterns[i], g), ec)) later = g;
    // Frame numbers are times (first_frame_time + f dt): a gap cannot be closed by renumbering.
    const std::string fix =
        later < 0 ? fmt::format("provide the file or lower frame_count to {} (for frames the recording dropped, number "
                                 "the files on and give each file's time in frame_times)", f)
                  : fmt::format("frame {} is there, so this is a gap: a frame without any measurement still needs its "
                                "file; write an all-zero {}x{} 16-bit PNG there (0 = no reading). Lowering frame_count "
                                "would drop every later frame",
                                later, set.cameras[i].width, set.cameras[i].height);
    throw InputError(fmt::format("{}: frame {} of {} is missing: {} does not exist ({} says frame_count = {}); {}",
                                 folder.string(), f, camera_label(set, i), png.string(), json_file, set.frame_count,
                                 fix));
  }
  DepthImage image = read_depth_png(png.string(), set.depth_scale);
  const std::string cam_where = fmt::format("cameras[{}] of {}", i, json_file);
  check_image_size(image, set.cameras[i], png.string(), cam_where);
  check_depth_values(image, set.cameras[i], 0.5000001 * set.depth_scale, png.string(), cam_where);
  return image;
}

void read_frames(ObservationSet& set, const fs::path& folder, const std::string& json_file) {
  set.frames.assign(set.frame_count, {});
  for (int f = 0; f < set.frame_count; ++f)
    for (std::size_t i = 0; i < set.cameras.size(); ++i)
      set.frames[f].push_back(read_frame(set, folder, f, i, json_file));
}

}  // namespace

const DepthNoise* camera_depth_noise(const ObservationSet& set, int camera) {
  if (camera < 0 || size_t(camera) >= set.depth_noise.size() || !set.depth_noise[size_t(camera)]) return nullptr;
  return &*set.depth_noise[size_t(camera)];
}

double frame_time(const ObservationSet& set, int frame) {
  return set.frame_times.empty() ? set.first_frame_time + frame * set.dt : set.frame_times.at(std::size_t(frame));
}

std::string default_depth_pattern(int camera) { return fmt::format("cam{}/depth_%04d.png", camera); }

std::string depth_file_name(const std::string& pattern, int frame, const std::string& where) {
  const Pattern p = parse_pattern(pattern, where);
  check_pattern_path(pattern, where);
  if (frame < 0) throw InputError(fmt::format("{}: negative frame number {}", where, frame));
  const std::string number =
      p.zero_pad ? fmt::format("{:0{}d}", frame, p.width) : fmt::format("{:>{}d}", frame, p.width);
  return p.prefix + number + p.suffix;
}

void validate_observations(const ObservationSet& set, const std::string& where) {
  validate_with_patterns(set, patterns_or_default(set), where);
}

void write_observation_files(const std::string& folder, const ObservationSet& set) {
  const std::vector<std::string> patterns = patterns_or_default(set);
  validate_with_patterns(set, patterns, fmt::format("write_observations({})", folder));
  write_header(folder, set, patterns);
  write_frames(folder, set, patterns);
}

void write_observations(const std::string& dir, const ObservationSet& set) {
  validate_with_patterns(set, patterns_or_default(set), fmt::format("write_observations({})", dir));
  OutputDir out(dir);
  write_observation_files(out.path(), set);
  out.commit();
}

ObservationSet read_observations(const std::string& dir) {
  const fs::path folder(dir);
  const fs::path json_path = folder / "cameras.json";
  std::error_code ec;
  if (fs::exists(folder, ec) && !fs::is_directory(folder, ec))
    throw InputError(fmt::format("{}: is a file, not a folder; give the observation folder that holds cameras.json "
                                 "and the depth PNGs", dir));
  if (!fs::is_directory(folder, ec))
    throw InputError(fmt::format("{}: observation folder does not exist; give the folder that holds "
                                 "cameras.json and the depth PNGs", dir));
  if (fs::is_directory(json_path, ec))
    throw InputError(fmt::format("{}: is a folder; cameras.json must be a JSON file ({})", json_path.string(), kDocs));
  if (!fs::exists(json_path, ec))
    throw InputError(fmt::format("{}: missing cameras.json; an observation folder needs it ({})",
                                 json_path.string(), kDocs));
  const std::string json_file = json_path.string();
  ObservationSet set = parse_header(parse_json_file(json_path), json_file);
  read_frames(set, folder, json_file);
  return set;
}

ObservationSet read_observation_header(const std::string& json_file) {
  std::error_code ec;
  if (!fs::is_regular_file(json_file, ec))
    throw InputError(fmt::format("{}: no such file; give an observation folder's cameras.json ({})", json_file, kDocs));
  return parse_header(parse_json_file(json_file), json_file);
}

std::vector<Eigen::Vector3d> observed_points(const ObservationSet& set, int frame) {
  if (frame < 0 || frame >= int(set.frames.size()))
    throw InputError(fmt::format("observed_points: frame {} is outside the observation set (frames 0..{})",
                                 frame, int(set.frames.size()) - 1));
  std::vector<Eigen::Vector3d> points;
  for (std::size_t i = 0; i < set.cameras.size(); ++i) {
    const DepthImage& image = set.frames[frame][i];
    for (int v = 0; v < image.height; ++v)
      for (int u = 0; u < image.width; ++u)
        if (image.at(u, v) > 0) points.push_back(unproject(set.cameras[i], u, v, image.at(u, v)));
  }
  return points;
}

}  // namespace ssc
