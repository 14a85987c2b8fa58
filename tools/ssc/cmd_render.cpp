// `ssc render MESHES --cameras FILE --out DIR`: renders a sequence of triangle-mesh frames
// (PLY, e.g. from another simulator) into the observation format
// (docs/observation-format.md) with ssc's depth renderer, so that data from any source can
// be fitted and diagnosed like ssc's own renders.
#include <fmt/format.h>

#include <cmath>
#include <nlohmann/json.hpp>
#include <optional>

#include "models/geometry/mesh.h"
#include "models/io/json_reader.h"
#include "models/io/output_dir.h"
#include "models/observation/depth_render.h"
#include "models/observation/observation_set.h"
#include "models/sim/observation_setup.h"
#include "runtime/errors.h"
#include "tools/ssc/commands.h"
#include "tools/ssc/mesh_sequence.h"
#include "tools/ssc/progress.h"

namespace ssc {
namespace {

struct RenderOptions {
  std::vector<std::string> meshes;
  std::string cameras, out, times;
  double fps = 0, dt = 0, first_time = 0;
  std::optional<double> noise, depth_scale;
  std::optional<std::uint64_t> seed;
  ProgressMode progress = ProgressMode::Auto;
};

// The cameras and the depth settings of a cameras file: an observation folder's
// cameras.json (format ssc-depth-v1), a scene with an observation section, or an object
// holding an observation section's keys.
ObservationSpec read_camera_file(const std::string& file) {
  const nlohmann::json j = read_json_file(file);
  if (j.is_object() && j.contains("format")) {
    const ObservationSet header = read_observation_header(file);
    ObservationSpec spec;
    spec.cameras = header.cameras;
    spec.depth_scale = header.depth_scale;
    return spec;
  }
  if (j.is_object() && j.contains("observation")) return parse_observation_section(j.at("observation"), file, "observation");
  if (j.is_object() && j.contains("cameras")) return parse_observation_section(j, file, "");
  throw InputError(fmt::format("{}: has no camera; give an observation folder's cameras.json (\"format\": \"{}\"), "
                               "a scene with observation.cameras, or an object with a 'cameras' array "
                               "(docs/cli.md#render)",
                               file, kObservationFormat));
}

int run_render(const RenderOptions& o) {
  const std::vector<std::string> files = list_mesh_frames(o.meshes);
  ObservationSpec spec = read_camera_file(o.cameras);
  if (o.noise) {
    if (!(*o.noise >= 0) || !std::isfinite(*o.noise))
      throw InputError(fmt::format("--noise {}: must be a non-negative depth noise in metres", *o.noise));
    spec.noise = *o.noise;
  }
  if (o.seed) spec.seed = *o.seed;
  if (o.depth_scale) {
    if (!(*o.depth_scale > 0) || !std::isfinite(*o.depth_scale))
      throw InputError(fmt::format("--depth-scale {}: must be a positive number of metres per PNG unit", *o.depth_scale));
    spec.depth_scale = *o.depth_scale;
  }
  const FrameTimes times = frame_times(int(files.size()), o.fps, o.dt, o.times, o.first_time);

  std::vector<std::string> inputs = files;
  inputs.push_back(o.cameras);
  if (!o.times.empty()) inputs.push_back(o.times);
  OutputDir out(o.out, inputs);
  out.manifest()["meshes"] = files;
  out.manifest()["cameras_file"] = o.cameras;
  out.manifest()["render"] = {{"first_frame_time", times.first}, {"dt", times.dt},     {"noise", spec.noise},
                              {"seed", spec.seed},                {"depth_scale", spec.depth_scale}};

  ObservationSet set;
  set.dt = times.dt;
  set.first_frame_time = times.first;
  set.depth_scale = spec.depth_scale;
  set.cameras = spec.cameras;
  set.frame_count = int(files.size());
  Progress progress("render: frame", set.frame_count, o.progress);
  size_t points = 0;
  for (int f = 0; f < set.frame_count; ++f) {
    const TriangleMesh mesh = load_mesh(files[f]);
    std::vector<std::array<int, 3>> triangles;
    triangles.reserve(mesh.faces.size());
    for (const Eigen::Vector3i& t : mesh.faces) triangles.push_back({t.x(), t.y(), t.z()});
    const TriangleBvh bvh(mesh.vertices, triangles);
    std::vector<DepthImage> images;
    for (size_t c = 0; c < set.cameras.size(); ++c) {
      images.push_back(render_depth(set.cameras[c], bvh, spec.noise, mix_seed(spec.seed, std::uint64_t(f), c)));
      for (double d : images.back().depth) points += d > 0;
    }
    set.frames.push_back(std::move(images));
    progress.update(f + 1);
  }
  progress.finish();
  if (points == 0)
    throw InputError(fmt::format("{}: no camera sees any of the {} meshes (every depth pixel is empty); check the "
                                 "cameras' poses and depth range against the meshes' coordinates (metres)",
                                 o.cameras, files.size()));
  write_observation_files(out.path(), set);
  out.commit();
  std::printf("wrote %s: %d frames x %zu cameras, %zu depth measurements, frames at %g + k * %g s, noise %.3g m\n",
              o.out.c_str(), set.frame_count, set.cameras.size(), points, times.first, times.dt, spec.noise);
  return 0;
}

}  // namespace

Command register_render(CLI::App& app) {
  auto o = std::make_shared<RenderOptions>();
  CLI::App* sub = app.add_subcommand("render", "Render a sequence of mesh frames (PLY) into depth observations");
  sub->add_option("meshes", o->meshes, "PLY frames: files, a folder or a quoted glob, ordered by name")->required();
  sub->add_option("--cameras", o->cameras,
                  "Cameras: an observation cameras.json, a scene with an observation section, or its 'cameras'")
      ->required();
  sub->add_option("--out", o->out, "Observation folder to write (replaced atomically)")->required();
  sub->add_option("--fps", o->fps, "Frame rate of the meshes, 1/s");
  sub->add_option("--dt", o->dt, "Time between two mesh frames, s");
  sub->add_option("--times", o->times, "File with one time (s) per frame, evenly spaced");
  sub->add_option("--first-time", o->first_time, "Time of the first frame with --fps or --dt, s");
  sub->add_option("--noise", o->noise, "Depth noise std along the ray, m (default: the cameras file's, else 0)");
  sub->add_option("--seed", o->seed, "Noise seed (default: the cameras file's, else 42)");
  sub->add_option("--depth-scale", o->depth_scale, "Metres per PNG unit (default: the cameras file's, else 1e-4)");
  add_progress_options(sub, &o->progress);
  return [o] { return run_render(*o); };
}

}  // namespace ssc
