// `ssc prepare RECORDING --mesh SCAN --out DIR`: a raw depth recording (Open3D, TUM RGB-D or
// a plain folder of depth PNGs) and a scan of the object become DIR/scene.json and
// DIR/observations/, ready for `reconstruct`, `residuals` and `diagnose` as they are, with
// pictures to check the segmentation and the pose (models/recording/prepare.h).
#include <fmt/format.h>

#include <filesystem>
#include <sstream>

#include "models/io/output_dir.h"
#include "models/io/run_record.h"
#include "models/io/text_file.h"
#include "models/recording/prepare.h"
#include "models/recording/prepare_pictures.h"
#include "runtime/errors.h"
#include "tools/ssc/commands.h"
#include "tools/ssc/progress.h"

namespace fs = std::filesystem;

namespace ssc {
namespace {

struct PrepareCli {
  std::string recording, mesh, out, frames, gravity, pick, noise;
  PrepareOptions options;
  std::optional<double> mass, density, depth_scale, fps;
  ProgressMode progress = ProgressMode::Auto;
};

std::vector<double> numbers_option(const std::string& text, size_t count, const std::string& option,
                                   const std::string& example) {
  std::vector<double> v;
  std::stringstream in(text);
  std::string item;
  while (std::getline(in, item, ',')) {
    size_t used = 0;
    double x = NAN;
    try {
      x = std::stod(item, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (used != item.size() || !std::isfinite(x))
      throw InputError(fmt::format("{} '{}': '{}' is not a number; give {}", option, text, item, example));
    v.push_back(x);
  }
  if (v.size() != count)
    throw InputError(fmt::format("{} '{}': give {} numbers, {}", option, text, count, example));
  return v;
}

void copy_file_bytes(const std::string& from, const std::string& to) {
  std::error_code ec;
  fs::copy_file(from, to, fs::copy_options::overwrite_existing, ec);
  if (ec) throw InputError(fmt::format("{}: cannot copy the scan to {} ({})", from, to, ec.message()));
}

int run_prepare(PrepareCli& c) {
  if (c.mass && c.density) throw InputError("give --mass or --density, not both (the scan's volume links them)");
  PrepareOptions& o = c.options;
  o.recording_folder = c.recording;
  o.mesh = c.mesh;
  o.recording.depth_scale = c.depth_scale;
  o.recording.fps = c.fps;
  o.mass = c.mass;
  o.density = c.density;
  if (!c.frames.empty()) parse_frame_range(c.frames, &o.recording);
  if (!c.gravity.empty()) {
    const auto g = numbers_option(c.gravity, 3, "--gravity", "the accelerometer's reading at rest, e.g. 0,-9.81,0");
    o.gravity = Eigen::Vector3d(g[0], g[1], g[2]);
  }
  if (!c.pick.empty()) {
    const auto uv = numbers_option(c.pick, 2, "--pick", "a pixel u,v of the object in the first frame");
    o.pick = Eigen::Vector2d(uv[0], uv[1]);
  }
  if (!c.noise.empty()) {
    const auto n = numbers_option(c.noise, 2, "--noise", "sigma0_m,per_m2, e.g. 0.0012,0.0019");
    if (n[0] < 0 || n[1] < 0 || n[0] + n[1] <= 0)
      throw InputError(fmt::format("--noise '{}': sigma0_m and per_m2 must be >= 0, not both 0", c.noise));
    o.noise = SensorNoise{n[0], n[1]};
  }
  if (!(o.scan_scale > 0) || !std::isfinite(o.scan_scale))
    throw InputError(fmt::format("--scan-scale {}: must be a positive number of metres per scan unit", o.scan_scale));
  if (!fs::is_regular_file(c.mesh))
    throw InputError(fmt::format("{}: the scan does not exist (--mesh: a .ply, .obj or .stl file)", c.mesh));
  OutputDir out(c.out, {c.recording, c.mesh});
  Progress progress("prepare", 1, c.progress);
  o.stage = [&](const std::string& what) { progress.stage(what); };
  const PreparedRecording p = prepare_recording(o);
  const std::string scan_name = scan_file_name(c.mesh);
  copy_file_bytes(c.mesh, out.file(scan_name));
  write_text_file(out.file("scene.json"), p.scene.dump(2) + "\n");
  write_observation_files(out.make_folder("observations"), p.observations);
  nlohmann::json summary = p.summary;
  summary["pictures"] = write_prepare_pictures(out.path(), p);
  summary["warnings"] = warnings_json();
  write_text_file(out.file("prepare.json"), summary.dump(2) + "\n");
  out.manifest()["recording"] = c.recording;
  out.manifest()["scan"] = c.mesh;
  out.commit();
  int contacts = 0;
  for (const PreparedPlane& plane : p.planes) contacts += plane.contact;
  const Eigen::Vector3d& v = p.velocity.linear;
  std::printf("wrote %s: scene.json (%d contact planes of %zu found, initial velocity %.3f %.3f %.3f m/s), "
              "observations/ (%zu frames), prepare.json and pictures; next: ssc reconstruct %s/scene.json "
              "--observations %s/observations --fit youngs_modulus --out FIT\n",
              c.out.c_str(), contacts, p.planes.size(), v.x(), v.y(), v.z(), p.recording.frames.size(), c.out.c_str(),
              c.out.c_str());
  return 0;
}

}  // namespace

Command register_prepare(CLI::App& app) {
  auto c = std::make_shared<PrepareCli>();
  CLI::App* sub = app.add_subcommand("prepare", "Turn a raw depth recording and a scan into a scene and observations");
  sub->add_option("recording", c->recording, "The recording's folder (Open3D, TUM RGB-D, or depth PNGs)")->required();
  sub->add_option("--mesh", c->mesh, "The object's scan (.ply, .obj, .stl), in its own frame")->required();
  sub->add_option("--out", c->out, "Folder to write (replaced atomically)")->required();
  sub->add_option("--format", c->options.recording.format, "auto, open3d, tum or folder")
      ->check(CLI::IsMember({"auto", "open3d", "tum", "folder"}));
  sub->add_option("--intrinsics", c->options.recording.intrinsics, "fx,fy,cx,cy (pixels) or a JSON file");
  sub->add_option("--depth-scale", c->depth_scale, "Metres per PNG unit (default: the format's)");
  sub->add_option("--fps", c->fps, "Frames per second (recordings without timestamps)");
  sub->add_option("--frames", c->frames, "Frames A:B of the recording (B excluded)");
  sub->add_option("--gravity", c->gravity, "Accelerometer reading at rest in the depth camera's frame, gx,gy,gz");
  sub->add_option("--mass", c->mass, "The object's mass, kg");
  sub->add_option("--density", c->density, "The object's density, kg/m^3");
  sub->add_option("--scan-scale", c->options.scan_scale, "Metres per scan unit (0.001 for a scan in millimetres)");
  sub->add_option("--pick", c->pick, "A pixel u,v of the object in the first frame");
  sub->add_option("--noise", c->noise, "Depth noise sigma0_m,per_m2: sigma(z) = sigma0 + per_m2 z^2 (default 0.0012,0.0019)");
  sub->add_option("--resolution", c->options.resolution, "Grid cells across the object")->check(CLI::Range(2, 300));
  sub->add_option("--substeps", c->options.substeps, "Simulation steps per frame (default: dt <= 5 ms)")
      ->check(CLI::Range(0, 1000));
  sub->add_option("--youngs-modulus", c->options.youngs_modulus, "The scene's Young's modulus, Pa (a fit's start)")
      ->check(CLI::PositiveNumber);
  sub->add_option("--contact-stiffness", c->options.contact_stiffness, "Contact planes' stiffness, Pa/m")
      ->check(CLI::PositiveNumber);
  sub->add_option("--softmin-alpha", c->options.softmin_alpha, "Contact planes' soft-min sharpness, 1/m")
      ->check(CLI::PositiveNumber);
  add_progress_options(sub, &c->progress);
  return [c] { return run_prepare(*c); };
}

}  // namespace ssc
