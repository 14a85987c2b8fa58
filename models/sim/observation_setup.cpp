// Observation set-up, synthetic rendering and frame mapping (see observation_setup.h).
#include "models/sim/observation_setup.h"

#include <fmt/format.h>

#include <cmath>

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
  const int frames = scene.time.steps / spec.every + 1;
  for (int f = 0; f < frames; ++f) {
    while (sim.steps_taken() < f * spec.every) sim.step();
    const TriangleBvh bvh(surface.positions(sim.displacement(0)), surface.triangles());
    std::vector<DepthImage> images;
    for (size_t c = 0; c < spec.cameras.size(); ++c)
      images.push_back(render_depth(spec.cameras[c], bvh, spec.noise, mix_seed(spec.seed, std::uint64_t(f), c)));
    set.frames.push_back(std::move(images));
    if (progress) progress(f + 1, frames);
  }
  set.frame_count = frames;
  if (finished) finished(sim);
  return set;
}

std::vector<ObservedFrame> observed_frames(const ObservationSet& set, double sim_dt, const std::string& dir) {
  std::vector<ObservedFrame> frames;
  for (int f = 0; f < set.frame_count; ++f) {
    const double t = set.first_frame_time + f * set.dt;
    const double steps = t / sim_dt;
    const double rounded = std::round(steps);
    if (std::abs(steps - rounded) > 1e-6 * std::max(1.0, steps))
      throw InputError(fmt::format("{}: frame {} is at t = {} s, which is not a multiple of the scene's time.dt = {} s; "
                                   "set time.dt so that the camera's frame interval dt = {} s is a whole number of steps",
                                   dir, f, t, sim_dt, set.dt));
    ObservedFrame frame;
    frame.step = int(rounded);
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
