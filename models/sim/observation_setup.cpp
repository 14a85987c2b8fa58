// Observation set-up, synthetic rendering and frame mapping (see observation_setup.h).
#include "models/sim/observation_setup.h"

#include <fmt/format.h>

#include <cmath>
#include <filesystem>

#include "runtime/errors.h"
#include "models/io/json_reader.h"
#include "models/observation/depth_render.h"
#include "models/sim/deformed_surface.h"
#include "models/sim/simulation.h"

namespace ssc {
namespace {

DepthCamera read_camera(const JsonReader& r, int index) {
  const std::string name = r.string("name", fmt::format("cam{}", index));
  const int width = r.integer("width"), height = r.integer("height");
  r.require(width > 0 && width <= 8192, "width", "must be between 1 and 8192 pixels");
  r.require(height > 0 && height <= 8192, "height", "must be between 1 and 8192 pixels");
  DepthCamera cam;
  if (r.has("eye")) {
    const double fov = r.number("fov_deg", 45.0);
    r.require(fov > 0 && fov < 179, "fov_deg", "must be in (0, 179) degrees");
    const Eigen::Vector3d eye = r.vec3("eye"), target = r.vec3("target"), up = r.vec3("up", Eigen::Vector3d(0, 1, 0));
    r.require((target - eye).norm() > 0, "target", "must differ from eye");
    r.require((target - eye).normalized().cross(up.normalized()).norm() > 1e-6, "up", "must not be parallel to the viewing direction");
    cam = make_look_at_camera(name, width, height, fov, eye, target, up);
  } else {
    cam.name = name;
    cam.width = width;
    cam.height = height;
    cam.fx = r.number("fx");
    cam.fy = r.number("fy");
    cam.cx = r.number("cx");
    cam.cy = r.number("cy");
    const std::vector<double> m = r.numbers("camera_to_world");
    r.require(m.size() == 16, "camera_to_world", "must hold 16 numbers (row-major 4x4)");
    for (int i = 0; i < 16; ++i) cam.camera_to_world(i / 4, i % 4) = m[i];
  }
  cam.min_depth = r.positive("min_depth", r.number("min_depth", 0.05));
  cam.max_depth = r.positive("max_depth", r.number("max_depth", 6.0));
  r.reject_unknown_keys();
  validate_camera(cam, r.full_key(""));
  return cam;
}

}  // namespace

ObservationSpec parse_observation_spec(const Scene& scene) {
  if (!scene.extra.contains("observation"))
    throw InputError(fmt::format("{}: has no 'observation' section (cameras, every, noise); see docs/scene-format.md", scene.file));
  return parse_observation_section(scene.extra.at("observation"), scene.file, "observation");
}

ObservationSpec parse_observation_section(const nlohmann::json& section, const std::string& file,
                                          const std::string& key) {
  const JsonReader r(section, file, key);
  ObservationSpec s;
  s.every = r.integer("every", s.every);
  r.require(s.every >= 1, "every", "must be at least 1");
  s.noise = r.non_negative("noise", r.number("noise", s.noise));
  s.seed = std::uint64_t(r.integer("seed", int(s.seed)));
  s.depth_scale = r.positive("depth_scale", r.number("depth_scale", s.depth_scale));
  s.phi_max = r.non_negative("phi_max", r.number("phi_max", 0.0));
  const std::vector<JsonReader> cams = r.array_of_objects("cameras");
  r.require(!cams.empty(), "cameras", "must list at least one camera");
  for (size_t i = 0; i < cams.size(); ++i) {
    s.cameras.push_back(read_camera(cams[i], int(i)));
    cams[i].require(s.cameras.back().max_depth <= 65535 * s.depth_scale, "max_depth",
                    fmt::format("is {} m, beyond what 16-bit depth with observation.depth_scale = {} m can hold ({} m); "
                                "raise depth_scale or lower max_depth",
                                s.cameras.back().max_depth, s.depth_scale, 65535 * s.depth_scale));
  }
  r.reject_unknown_keys();
  return s;
}

ObservationSet render_observations(const Scene& scene, const SimGrid& grid, const ObservationSpec& spec,
                                   const std::function<void(int, int)>& progress,
                                   const std::function<void(Simulation&)>& configure,
                                   const std::function<void(const Simulation&)>& finished) {
  Simulation sim(scene, grid);
  if (configure) configure(sim);
  const DeformedSurface surface(grid);
  ObservationSet set;
  set.dt = spec.every * scene.time.dt;
  set.depth_scale = spec.depth_scale;
  set.first_frame_time = 0;
  set.cameras = spec.cameras;
  for (size_t c = 0; c < spec.cameras.size(); ++c) set.depth_patterns.push_back(default_depth_pattern(int(c)));
  // The renderer's noise, so that a fit can be compared with it (models/diagnosis/goodness_of_fit.h).
  set.depth_noise.assign(spec.cameras.size(), DepthNoise{spec.noise, 0.0, true});
  const int frames = scene.time.steps / spec.every + 1;
  for (int f = 0; f < frames; ++f) {
    while (sim.steps_taken() < f * spec.every) sim.step();
    const TriangleBvh bvh(surface.positions(sim.displacement(0)), surface.triangles());
    std::vector<DepthImage> images;
    for (size_t c = 0; c < spec.cameras.size(); ++c)
      images.push_back(render_depth(spec.cameras[c], bvh, spec.noise, mix_seed(spec.seed, std::uint64_t(f), c)));
    set.frames.push_back(std::move(images));
    set.frame_times.push_back(f * spec.every * scene.time.dt);
    if (progress) progress(f + 1, frames);
  }
  set.frame_count = frames;
  if (finished) finished(sim);
  return set;
}

namespace {

// The step of a frame with a time of its own (cameras.json frame_times): the nearest one,
// within kFrameTimeStepTolerance steps; two frames may not share a step.
int step_of_frame_time(const ObservationSet& set, int f, double sim_dt, int previous, const std::string& file) {
  const double t = set.frame_times[std::size_t(f)];
  const double steps = t / sim_dt;
  const double rounded = std::round(steps);
  if (rounded < 0)
    throw InputError(fmt::format("{}: frame_times[{}] = {} s is before the simulation starts (t = 0); the times are "
                                 "measured from the start of the simulated motion", file, f, t));
  if (std::abs(steps - rounded) > kFrameTimeStepTolerance)
    throw InputError(fmt::format(
        "{}: frame_times[{}] = {} s lies {:.3g} steps from the nearest simulation step (t = {} s with the scene's "
        "time.dt = {} s; at most {} of a step is allowed); choose time.dt so that the frame times fall on steps, or "
        "round frame_times to multiples of it",
        file, f, t, std::abs(steps - rounded), rounded * sim_dt, sim_dt, kFrameTimeStepTolerance));
  if (int(rounded) == previous)
    throw InputError(fmt::format("{}: frame_times[{}] = {} s and frame_times[{}] = {} s fall on the same simulation "
                                 "step (time.dt = {} s); lower the scene's time.dt",
                                 file, f - 1, set.frame_times[std::size_t(f - 1)], f, t, sim_dt));
  return int(rounded);
}

}  // namespace

std::vector<ObservedFrame> observed_frames(const ObservationSet& set, double sim_dt, const std::string& dir) {
  std::vector<ObservedFrame> frames;
  const std::string file = (std::filesystem::path(dir) / "cameras.json").string();
  for (int f = 0; f < set.frame_count; ++f) {
    ObservedFrame frame;
    if (!set.frame_times.empty()) {
      frame.step = step_of_frame_time(set, f, sim_dt, f > 0 ? frames.back().step : -1, file);
    } else {
      const double t = frame_time(set, f);
      const double steps = t / sim_dt;
      const double rounded = std::round(steps);
      if (std::abs(steps - rounded) > 1e-6 * std::max(1.0, steps))
        throw InputError(fmt::format("{}: frame {} is at t = {} s, which is not a multiple of the scene's time.dt = {} s; "
                                     "set time.dt so that the camera's frame interval dt = {} s is a whole number of steps",
                                     dir, f, t, sim_dt, set.dt));
      frame.step = int(rounded);
    }
    frame.points = observed_points(set, f);
    frames.push_back(std::move(frame));
  }
  size_t total = 0;
  for (const ObservedFrame& f : frames) total += f.points.size();
  if (total == 0)
    throw InputError(fmt::format("{}: no depth image has a single measurement (all pixels are 0); check the cameras' "
                                 "poses and depth range",
                                 dir));
  return frames;
}

}  // namespace ssc
