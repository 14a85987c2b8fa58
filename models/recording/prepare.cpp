// The pipeline of prepare.h; the scene and observations it leads to: prepare_output.cpp.
#include "models/recording/prepare.h"

#include <fmt/format.h>

#include <Eigen/LU>
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>

#include "models/geometry/mesh.h"
#include "models/io/run_record.h"
#include "models/recording/depth_points.h"
#include "models/recording/object_selection.h"
#include "models/recording/object_tracking.h"
#include "models/recording/scene_planes.h"
#include "models/recording/world_frame.h"
#include "runtime/errors.h"

namespace ssc {

namespace {

void stage(const PrepareOptions& o, const std::string& what) {
  if (o.stage) o.stage(what);
}

// The image the planes are looked for in: the static background where the recording has
// one (what stays when the object moves on), else the first frame.
DepthImage plane_search_image(const DepthRecording& r, const std::vector<double>& background) {
  DepthImage img = r.frames.front();
  if (!background.empty()) img.depth = background;
  return img;
}

std::vector<char> mask_of(const DepthComponent& part, size_t pixels) {
  std::vector<char> mask(pixels, 0);
  for (int i : part.pixels) mask[std::size_t(i)] = 1;
  return mask;
}

}  // namespace

ImagePlanes find_image_planes(const DepthImage& image, const DepthIntrinsics& k, const SensorNoise& noise,
                              double depth_scale) {
  ImagePlanes out;
  out.stride = std::max(1, int(std::sqrt(double(k.width) * k.height / 40000.0)));
  out.points = pixel_points(image, k, nullptr, out.stride);
  std::vector<double> band;
  for (const Eigen::Vector3d& q : out.points.points) band.push_back(noise_band(noise, q.z(), depth_scale));
  out.planes = find_planes(out.points.points, band, Eigen::Vector3d::Zero());
  return out;
}

PreparedRecording prepare_recording(const PrepareOptions& o) {
  PreparedRecording p;
  stage(o, "reading the recording");
  p.recording = read_recording(o.recording_folder, o.recording);
  const DepthRecording& rec = p.recording;
  const DepthIntrinsics& k = rec.intrinsics;
  const std::string where = rec.folder;
  p.timing = regularise_timestamps(rec.timestamps, o.recording.fps ? 1 / *o.recording.fps : 1.0 / 30,
                                   rec.format == "tum" ? rec.folder + "/depth.txt" : rec.folder);

  stage(o, "finding the planes");
  const std::vector<double> background = far_background(rec.frames, o.noise, rec.depth_scale);
  {  // a camera at rest reads the same depth, within the noise, nearly everywhere the object is not
    const DepthImage& first = rec.frames.front();
    const DepthImage& last = rec.frames.back();
    size_t both = 0, changed = 0;
    for (size_t i = 0; i < first.depth.size(); ++i)
      if (first.depth[i] > 0 && last.depth[i] > 0) {
        ++both;
        changed += std::abs(last.depth[i] - first.depth[i]) > noise_band(o.noise, first.depth[i], rec.depth_scale);
      }
    if (rec.frames.size() > 1 && 2 * changed > both)
      warn("camera_moving", fmt::format("{}: {:.0f} % of the pixels read another depth in the last frame than in the "
                                        "first: the camera seems to move, but prepare assumes a camera at rest (its "
                                        "motion would be taken for the object's); record with the camera fixed", where,
                                        100.0 * double(changed) / double(std::max<size_t>(both, 1))));
  }
  const DepthImage search_image = plane_search_image(rec, background);
  const ImagePlanes found = find_image_planes(search_image, k, o.noise, rec.depth_scale);
  p.plane_stride = found.stride;
  for (const DetectedPlane& d : found.planes) {
    PreparedPlane plane;
    plane.camera = d.plane;
    plane.rms = d.rms;
    for (int i : d.inliers) plane.pixels.push_back(found.points.pixels[std::size_t(i)]);
    p.planes.push_back(std::move(plane));
  }

  stage(o, "segmenting the first frame");
  SegmentationContext context;
  context.intrinsics = k;
  context.noise = o.noise;
  context.depth_scale = rec.depth_scale;
  for (const PreparedPlane& plane : p.planes) context.planes.push_back(plane.camera);
  context.background = background;
  const int min_pixels = std::max(20, int(0.0003 * k.width * k.height));
  p.first_classes = classify_pixels(rec.frames.front(), context);
  p.picture_classes.push_back(p.first_classes);
  const std::vector<DepthComponent> parts = depth_components(rec.frames.front(), p.first_classes, context, min_pixels);

  const TriangleMesh mesh = load_mesh(o.mesh);
  p.scan = make_scan_model(mesh, o.scan_scale);
  if (p.scan.open_edges > 0)
    warn("scan_not_closed", fmt::format("{}: the scan is not closed ({} edges do not join two faces): its inside is "
                                        "taken where the winding number is above 1/2 and its volume (for --mass) is "
                                        "approximate; close the holes for a reliable volume and mass", o.mesh, p.scan.open_edges));
  // The mass: given, or from the density and the scan's volume.
  if (o.mass && o.density) throw InputError("give --mass or --density, not both");
  if (o.mass) {
    if (!(*o.mass > 0)) throw InputError(fmt::format("--mass {}: must be a positive number of kilograms", *o.mass));
    if (!(p.scan.volume > 0))
      throw InputError(fmt::format("{}: --mass needs the scan's volume, but the scan encloses none; give --density "
                                   "(kg/m^3) instead, or close the scan", o.mesh));
    p.density = *o.mass / p.scan.volume;
  } else if (o.density) {
    if (!(*o.density > 0)) throw InputError(fmt::format("--density {}: must be a positive number of kg/m^3", *o.density));
    p.density = *o.density;
  } else {
    p.density = 1000;
    warn("density_default", "neither --mass nor --density given: the density is taken as 1000 kg/m^3 (water); give "
                            "the object's mass (--mass KG) for a Young's modulus in the right units");
  }
  p.mass = p.density * p.scan.volume;

  const double scan_extent = p.scan.extents[0];
  const int chosen = select_object_part(parts, scan_extent, o.scan_scale, o.pick, where);
  const DepthComponent& object = parts[std::size_t(chosen)];

  const int support = set_world_frame(p, object, search_image, o.gravity, where);

  stage(o, "registering the scan");
  const size_t pixel_count = size_t(k.width) * k.height;
  const int frames = int(rec.frames.size());
  p.object_masks.assign(std::size_t(frames), std::vector<char>());
  p.object_pixels.assign(std::size_t(frames), 0);
  p.poses.assign(std::size_t(frames), std::nullopt);
  p.icp_rms.assign(std::size_t(frames), 0.0);
  p.object_masks[0] = mask_of(object, pixel_count);
  p.object_pixels[0] = int(object.pixels.size());
  CameraView view;
  view.intrinsics = k;
  view.world_to_camera = p.camera_to_world.inverse();
  view.depth = &rec.frames.front();
  const double huber = 2 * o.noise.sigma(object.centroid.z());
  const std::vector<Eigen::Vector3d> first_points = object_points_world(rec.frames.front(), k, p.object_masks[0], p.camera_to_world);
  p.first_registration = register_scan(p.scan, first_points, view, huber);
  p.poses[0] = p.first_registration.icp.pose;
  p.icp_rms[0] = p.first_registration.icp.rms;

  stage(o, "tracking the object");
  track_object(p, context, min_pixels, huber, where);

  // Initial velocity from the first frames of free flight: before the scan comes within the
  // noise band (at least 5 mm) of the support.
  stage(o, "estimating the initial velocity");
  const PreparedPlane& floor = p.planes[std::size_t(support)];
  std::vector<RigidPose> flight;
  std::vector<double> times;
  const Eigen::Vector3d gravity = -p.gravity_magnitude * Eigen::Vector3d::UnitY();
  for (int f = 0; f < frames && int(flight.size()) < o.velocity_frames; ++f) {
    if (!p.poses[std::size_t(f)]) break;
    double lowest = 1e300;
    for (const Eigen::Vector3d& q : p.scan.points)
      lowest = std::min(lowest, floor.normal.dot(p.poses[std::size_t(f)]->apply(q)) - floor.height);
    if (lowest < std::max(0.005, noise_band(o.noise, object.centroid.z(), rec.depth_scale)) && f > 0) break;
    flight.push_back(*p.poses[std::size_t(f)]);
    times.push_back(p.timing.frame_index[std::size_t(f)] * p.timing.frame_dt);
  }
  p.velocity = estimate_velocity(flight, times, p.scan.centroid, gravity, p.scan.inertia);
  if (p.velocity.frames < 2)
    warn("no_initial_velocity", fmt::format("{}: the object is in free flight in fewer than 2 frames: the initial "
                                            "velocity is set to 0; fit it (--fit youngs_modulus,initial.linear_velocity)",
                                            where));

  mark_contact_planes(p, search_image);

  p.observations = prepared_observations(p, o);
  p.scene = prepared_scene(p, o, scan_file_name(o.mesh));
  p.summary = prepared_summary(p, o);
  return p;
}

}  // namespace ssc
