// What prepare writes, as data: the scene (the posed scan as the rest shape, the contact
// planes, gravity, the time axis, the material and the initial velocity), the observations
// (the object's depth only, on the world frame's camera) and the summary prepare.json.
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <filesystem>

#include "models/recording/prepare.h"
#include "models/recording/world_frame.h"

namespace ssc {

namespace {

nlohmann::json vec(const Eigen::Vector3d& v) {
  auto r = [](double x) { return std::abs(x) < 1e-12 ? 0.0 : x; };
  return nlohmann::json::array({r(v.x()), r(v.y()), r(v.z())});
}

std::vector<double> row_major(const Eigen::Matrix4d& m) {
  std::vector<double> out;
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) out.push_back(m(r, c));
  return out;
}

int substeps_of(const PreparedRecording& p, const PrepareOptions& o) {
  if (o.substeps > 0) return o.substeps;
  return std::max(1, int(std::ceil(p.timing.frame_dt / 0.005 - 1e-9)));
}

}  // namespace

std::string scan_file_name(const std::string& mesh) {
  std::string ext = std::filesystem::path(mesh).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  return "scan" + ext;
}

ObservationSet prepared_observations(const PreparedRecording& p, const PrepareOptions& o) {
  const DepthRecording& rec = p.recording;
  ObservationSet set;
  set.dt = p.timing.frame_dt;
  set.depth_scale = rec.depth_scale;
  set.frame_count = int(rec.frames.size());
  DepthCamera cam;
  cam.name = rec.format + " depth camera";
  cam.width = rec.intrinsics.width;
  cam.height = rec.intrinsics.height;
  cam.fx = rec.intrinsics.fx;
  cam.fy = rec.intrinsics.fy;
  cam.cx = rec.intrinsics.cx;
  cam.cy = rec.intrinsics.cy;
  cam.camera_to_world = p.camera_to_world;
  double lo = 1e300, hi = 0;
  for (size_t f = 0; f < rec.frames.size(); ++f) {
    DepthImage img = rec.frames[f];
    for (size_t i = 0; i < img.depth.size(); ++i) {
      if (!p.object_masks[f][i]) img.depth[i] = 0;
      if (img.depth[i] > 0) lo = std::min(lo, img.depth[i]), hi = std::max(hi, img.depth[i]);
    }
    set.frames.push_back({img});
    set.frame_times.push_back(p.timing.frame_index[f] * p.timing.frame_dt);
  }
  cam.min_depth = std::min(0.1, 0.9 * lo);
  cam.max_depth = std::max(10.0, 1.1 * hi);
  set.cameras.push_back(cam);
  set.depth_noise.push_back(DepthNoise{o.noise.sigma0, o.noise.per_m2, false});
  return set;
}

nlohmann::json prepared_scene(const PreparedRecording& p, const PrepareOptions& o, const std::string& mesh_name) {
  const RigidPose& pose = *p.poses[0];
  nlohmann::json planes = nlohmann::json::array();
  for (const PreparedPlane& plane : p.planes)
    if (plane.contact) planes.push_back({{"normal", vec(plane.normal)}, {"height", std::abs(plane.height) < 1e-12 ? 0.0 : plane.height}});
  const int substeps = substeps_of(p, o);
  const int frames_span = p.timing.frame_index.back();
  nlohmann::json scene = {
      {"name", "prepared"},
      {"description", fmt::format("made by ssc prepare from the {} recording {} and the scan {}", p.recording.format,
                                  p.recording.folder, o.mesh)},
      {"object", {{"mesh", mesh_name}, {"scale", o.scan_scale}, {"position", vec(pose.translation)},
                  {"rotation_deg", vec(euler_xyz_degrees(pose.rotation))}}},
      {"grid", {{"resolution", o.resolution}}},
      {"material", {{"youngs_modulus", o.youngs_modulus}, {"poisson_ratio", o.poisson_ratio}, {"density", p.density},
                    {"mass_damping", 0.1}, {"stiffness_damping", 0.001}}},
      {"gravity", vec(Eigen::Vector3d(0, -p.gravity_magnitude, 0))},
      {"initial", {{"linear_velocity", vec(p.velocity.linear)}, {"angular_velocity", vec(p.velocity.angular)}}},
      {"ground", {{"stiffness", o.contact_stiffness}, {"softmin_alpha", o.softmin_alpha}, {"planes", planes}}},
      {"time", {{"dt", p.timing.frame_dt / substeps}, {"steps", std::max(1, frames_span * substeps)}, {"theta", 0.6}}},
      // A stiff surface's contact within the step (docs/scene-format.md, stiff contact).
      {"solver", {{"contact", "implicit"}}}};
  return scene;
}

nlohmann::json prepared_summary(const PreparedRecording& p, const PrepareOptions& o) {
  nlohmann::json planes = nlohmann::json::array();
  for (const PreparedPlane& plane : p.planes)
    planes.push_back({{"normal", vec(plane.normal)}, {"height", plane.height}, {"camera_normal", vec(plane.camera.normal)},
                      {"camera_offset", plane.camera.offset}, {"inlier_pixels", plane.pixels.size()},
                      {"rms_m", plane.rms}, {"support", plane.support}, {"contact", plane.contact}});
  nlohmann::json frames = nlohmann::json::array();
  for (size_t f = 0; f < p.poses.size(); ++f) {
    nlohmann::json fr = {{"frame", f}, {"file", p.recording.files[f]}, {"timestamp", p.recording.timestamps[f]},
                         {"time", p.timing.frame_index[f] * p.timing.frame_dt}, {"object_pixels", p.object_pixels[f]}};
    if (p.poses[f]) {
      fr["centre_of_mass"] = vec(p.poses[f]->apply(p.scan.centroid));
      fr["rotation_deg"] = vec(euler_xyz_degrees(p.poses[f]->rotation));
      fr["icp_rms_m"] = p.icp_rms[f];
    }
    frames.push_back(fr);
  }
  return {{"recording", {{"format", p.recording.format}, {"folder", p.recording.folder},
                         {"intrinsics", {{"width", p.recording.intrinsics.width}, {"height", p.recording.intrinsics.height},
                                         {"fx", p.recording.intrinsics.fx}, {"fy", p.recording.intrinsics.fy},
                                         {"cx", p.recording.intrinsics.cx}, {"cy", p.recording.intrinsics.cy},
                                         {"source", p.recording.intrinsics_source}}},
                         {"depth_scale", p.recording.depth_scale}, {"frames", p.recording.frames.size()},
                         {"frame_dt", p.timing.frame_dt}, {"dropped_frames", p.timing.dropped}}},
          {"up_camera", vec(p.up_camera)},
          {"gravity_from", p.gravity_from_plane ? "the largest level plane" : "--gravity"},
          {"camera_to_world", row_major(p.camera_to_world)},
          {"planes", planes},
          {"scan", {{"file", o.mesh}, {"scale", o.scan_scale}, {"extents_m", vec(p.scan.extents)}, {"volume_m3", p.scan.volume},
                    {"open_edges", p.scan.open_edges}}},
          {"density", p.density}, {"mass", p.mass},
          {"registration", {{"hypotheses", p.first_registration.hypotheses}, {"icp_rms_m", p.first_registration.icp.rms},
                            {"matched_points", p.first_registration.icp.matched},
                            {"seen_through", p.first_registration.seen_through}}},
          {"initial_velocity", {{"linear", vec(p.velocity.linear)}, {"angular", vec(p.velocity.angular)},
                                {"frames", p.velocity.frames}}},
          {"noise", {{"sigma0_m", o.noise.sigma0}, {"per_m2", o.noise.per_m2}}},
          {"frames", frames}};
}

}  // namespace ssc
