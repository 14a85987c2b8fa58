// An observation set: depth images of a moving body from one or more calibrated depth
// cameras, the native input of ssc for synthetic renders and real RGB-D recordings alike.
// On disk it is a folder (docs/observation-format.md):
//
//   DIR/cameras.json                    format "ssc-depth-v1", dt, depth_scale, frame_count,
//                                       first_frame_time, optional frame_times and
//                                       depth_noise, cameras[] (intrinsics, pose, depth
//                                       range, depth_pattern, optional depth_noise)
//   DIR/<depth_pattern % frame>         one 16-bit depth PNG per camera per frame
//
// Frame f was taken at time frame_times[f] when the folder lists them (so a dropped frame is
// a gap, not a renumbering), else at first_frame_time + f * dt; what that time means for a
// simulation is the caller's business. The reader checks everything it loads and throws
// InputError with the offending path and the fix; the writer never leaves a half-written
// folder behind.
#pragma once
#include <Eigen/Core>
#include <optional>
#include <string>
#include <vector>

#include "models/observation/camera.h"
#include "models/observation/depth_png.h"

namespace ssc {

inline constexpr const char* kObservationFormat = "ssc-depth-v1";

// A depth sensor's noise model: the standard deviation of one measured depth z (metres) is
// sigma(z) = sigma0_m + per_m2 z^2 (the common model of structured-light and time-of-flight
// sensors), measured along the camera's z axis (the stored depth) or along the viewing ray.
struct DepthNoise {
  double sigma0_m = 0;  // metres
  double per_m2 = 0;    // 1/m: metres of noise per square metre of depth
  bool along_ray = false;
  double sigma(double z) const { return sigma0_m + per_m2 * z * z; }
  bool operator==(const DepthNoise& o) const {
    return sigma0_m == o.sigma0_m && per_m2 == o.per_m2 && along_ray == o.along_ray;
  }
};

struct ObservationSet {
  double dt = 0;                  // seconds between observed frames
  double depth_scale = 0.001;     // metres per PNG unit
  double first_frame_time = 0;    // seconds, time of frame 0
  int frame_count = 0;
  std::vector<double> frame_times;  // seconds, one per frame, strictly increasing; empty: regular
  std::vector<DepthCamera> cameras;
  std::vector<std::string> depth_patterns;         // per camera, relative to the folder
  std::vector<std::vector<DepthImage>> frames;     // frames[f][camera]
  std::vector<std::optional<DepthNoise>> depth_noise;  // per camera, or empty: none given
};

// The noise model of `camera`, or null when cameras.json gives none.
const DepthNoise* camera_depth_noise(const ObservationSet& set, int camera);
// Time of frame f in seconds: frame_times[f], or first_frame_time + f * dt without them.
double frame_time(const ObservationSet& set, int frame);

// "cam<i>/depth_%04d.png", the pattern write_observations uses for camera i when
// depth_patterns is empty.
std::string default_depth_pattern(int camera);

// The file name of `frame` under `pattern`: the pattern holds exactly one integer
// conversion %d or %0Nd (N <= 9), "%%" is a literal %. Throws InputError naming `where`
// for any other pattern (no conversion, two conversions, %s, an absolute path, "..").
std::string depth_file_name(const std::string& pattern, int frame, const std::string& where = "depth_pattern");

// Checks sizes and contents of an in-memory set (what write_observations will write):
// dt > 0, depth_scale > 0, frame_count >= 1 matching frames, frame_times (if any) one per
// frame, strictly increasing and spaced about dt apart, depth_noise (if any) >= 0, one image
// per camera per frame with the camera's size, valid cameras and patterns (distinct files),
// every depth 0 or in [min_depth, max_depth]. Throws InputError naming `where`.
void validate_observations(const ObservationSet& set, const std::string& where);

// Writes the set into `dir` as an ssc output folder (models/io/output_dir.h): atomically,
// with a manifest, replacing only a folder an earlier ssc run made (or an empty one).
// Empty depth_patterns means default patterns. Depths are quantised to depth_scale on disk.
void write_observations(const std::string& dir, const ObservationSet& set);
// The files alone (cameras.json and the PNGs) into an existing folder (an OutputDir's).
void write_observation_files(const std::string& folder, const ObservationSet& set);

// Reads and checks a folder written by write_observations or by a converter of a real
// recording. Every problem (missing cameras.json, malformed JSON, missing keys, wrong
// types, unknown format, bad camera, missing frame file, PNG size mismatch, depths outside
// the camera's depth range) is an InputError naming the file and the fix.
ObservationSet read_observations(const std::string& dir);

// cameras.json alone, checked as read_observations checks it; the set has no frames.
ObservationSet read_observation_header(const std::string& json_file);

// World points of every measured pixel (depth > 0) of every camera of `frame`, in camera
// order and row-major pixel order within a camera.
std::vector<Eigen::Vector3d> observed_points(const ObservationSet& set, int frame);

}  // namespace ssc
