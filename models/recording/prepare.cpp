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
#include "models/recording/world_frame.h"
#include "runtime/errors.h"

namespace ssc {

namespace {

constexpr double kFloorLikeCos = 0.866;  // a plane within 30 degrees of level can hold the object

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

std::vector<Eigen::Vector3d> object_points_world(const DepthImage& img, const DepthIntrinsics& k,
                                                 const std::vector<char>& mask, const Eigen::Matrix4d& c2w) {
  std::vector<Eigen::Vector3d> pts;
  const PixelPoints pp = pixel_points(img, k, &mask);
  for (const Eigen::Vector3d& p : pp.points) pts.push_back(c2w.topLeftCorner<3, 3>() * p + c2w.topRightCorner<3, 1>());
  return pts;
}

std::vector<char> mask_of(const DepthComponent& part, size_t pixels) {
  std::vector<char> mask(pixels, 0);
  for (int i : part.pixels) mask[std::size_t(i)] = 1;
  return mask;
}

// Distance from a camera-frame point to the nearest inlier of a plane (its inliers are pixels of `img`).
double distance_to_inliers(const Eigen::Vector3d& x, const std::vector<int>& pixels, const DepthImage& img,
                           const DepthIntrinsics& k) {
  double best = 1e300;
  for (size_t n = 0; n < pixels.size(); n += 3) {
    const int i = pixels[n];
    best = std::min(best, (back_project(k, i % img.width, i / img.width, img.depth[std::size_t(i)]) - x).squaredNorm());
  }
  return std::sqrt(best);
}

}  // namespace

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
  const DepthImage search_image = plane_search_image(rec, background);
  const int stride = std::max(1, int(std::sqrt(double(k.width) * k.height / 40000.0)));
  p.plane_stride = stride;
  const PixelPoints bg = pixel_points(search_image, k, nullptr, stride);
  std::vector<double> band;
  for (const Eigen::Vector3d& q : bg.points) band.push_back(noise_band(o.noise, q.z(), rec.depth_scale));
  const std::vector<DetectedPlane> found = find_planes(bg.points, band, Eigen::Vector3d::Zero());
  for (const DetectedPlane& d : found) {
    PreparedPlane plane;
    plane.camera = d.plane;
    plane.rms = d.rms;
    for (int i : d.inliers) plane.pixels.push_back(bg.pixels[std::size_t(i)]);
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
  const double scan_extent = p.scan.extents[0];
  const int chosen = select_object_part(parts, scan_extent, o.scan_scale, o.pick, where);
  const DepthComponent& object = parts[std::size_t(chosen)];

  // Up: the accelerometer's reading at rest points away from the ground (it measures the
  // support's push, not gravity); without it the largest floor-like plane under the object,
  // floor-like meaning within 45 degrees of the image's up (cameras are held about upright).
  if (o.gravity) {
    if (!(o.gravity->norm() > 0) || !o.gravity->allFinite())
      throw InputError("--gravity: give the accelerometer's reading at rest in the depth camera's frame, e.g. 0,-9.81,0");
    p.up_camera = o.gravity->normalized();
    p.gravity_magnitude = o.gravity->norm();
    if (std::abs(p.gravity_magnitude - 9.81) > 1.5)
      warn("gravity_magnitude", fmt::format("--gravity has magnitude {:.3g} m/s^2, not about 9.81: check its unit; the "
                                            "scene uses {:.3g}", p.gravity_magnitude, p.gravity_magnitude));
  } else {
    int best = -1;
    for (size_t i = 0; i < p.planes.size(); ++i) {
      const Plane& pl = p.planes[i].camera;
      if (pl.normal.dot(Eigen::Vector3d(0, -1, 0)) > std::cos(M_PI / 4) && pl.distance(object.centroid) > 0) {
        best = int(i);
        break;  // planes come largest first
      }
    }
    if (best < 0)
      throw InputError(fmt::format("{}: no plane under the object: none of the {} planes found is level enough (within "
                                   "45 degrees of the image's up) with the object above it; give the accelerometer's "
                                   "reading with --gravity gx,gy,gz, and make sure the table or floor the object "
                                   "falls onto is in view", where, p.planes.size()));
    p.up_camera = p.planes[std::size_t(best)].camera.normal;
    p.gravity_from_plane = true;
    warn("gravity_from_plane", fmt::format("{}: no --gravity: up is taken as the normal of the largest level plane "
                                           "({:.0f} pixels); give the accelerometer's reading at rest "
                                           "(--gravity gx,gy,gz in the depth camera's frame) if the surface is not level",
                                           where, double(p.planes[std::size_t(best)].pixels.size() * stride * stride)));
  }

  // The support: the nearest level plane below the object whose inliers reach under it.
  int support = -1;
  double support_drop = 1e300;
  for (size_t i = 0; i < p.planes.size(); ++i) {
    const Plane& pl = p.planes[i].camera;
    const double cos_up = pl.normal.dot(p.up_camera);
    if (cos_up < kFloorLikeCos) continue;
    const double drop = pl.distance(object.centroid) / cos_up;  // along up, from the object down to the plane
    if (drop <= 0) continue;
    const Eigen::Vector3d foot = object.centroid - drop * p.up_camera;
    if (distance_to_inliers(foot, p.planes[i].pixels, search_image, k) > std::max(0.1, scan_extent)) continue;
    if (drop < support_drop) support_drop = drop, support = int(i);
  }
  if (support < 0)
    throw InputError(fmt::format("{}: no plane under the object: of the {} planes found, none is level (within 30 "
                                 "degrees of up) and reaches under the object at (u, v) = ({:.0f}, {:.0f}); the table "
                                 "or floor it falls onto must be in view{}", where, p.planes.size(),
                                 object.pixel_centroid.x(), object.pixel_centroid.y(),
                                 p.gravity_from_plane ? "" : ", and --gravity must be the accelerometer's reading at rest (pointing up)"));
  p.planes[std::size_t(support)].support = true;
  const Eigen::Vector3d origin = object.centroid - support_drop * p.up_camera;
  p.camera_to_world = camera_to_world_from_up(p.up_camera, origin);
  const Eigen::Matrix3d R = p.camera_to_world.topLeftCorner<3, 3>();
  const Eigen::Vector3d t = p.camera_to_world.topRightCorner<3, 1>();
  for (PreparedPlane& plane : p.planes) {
    plane.normal = R * plane.camera.normal;
    plane.height = plane.camera.offset + plane.normal.dot(t);
  }

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
  std::vector<int> lost;
  Eigen::Vector3d last_centre = p.poses[0]->apply(p.scan.centroid), velocity = Eigen::Vector3d::Zero();
  RigidPose last_pose = *p.poses[0];
  int last_frame = 0;
  const double frame_dt = p.timing.frame_dt;
  const Eigen::Vector3d g_world(0, -p.gravity_magnitude, 0);
  for (int f = 1; f < frames; ++f) {
    const double dt = (p.timing.frame_index[std::size_t(f)] - p.timing.frame_index[std::size_t(last_frame)]) * frame_dt;
    const Eigen::Vector3d predicted = last_centre + velocity * dt + 0.5 * g_world * dt * dt;
    const std::vector<PixelClass> classes = classify_pixels(rec.frames[std::size_t(f)], context);
    if (f == (frames - 1) / 2 || f == frames - 1) p.picture_classes.push_back(classes);
    const std::vector<DepthComponent> fparts = depth_components(rec.frames[std::size_t(f)], classes, context, min_pixels);
    // The part nearest to where the object should be, and every part close to it (ears, a
    // handle, a side seen past an edge are parts of their own).
    std::vector<Eigen::Vector3d> centres;
    int best = -1;
    double best_d = 1e300;
    for (size_t i = 0; i < fparts.size(); ++i) {
      centres.push_back(R * fparts[i].centroid + t);
      const double d = (centres.back() - predicted).norm();
      if (d < best_d && d < scan_extent + 2 * velocity.norm() * dt + 0.05) best_d = d, best = int(i);
    }
    if (best < 0) {
      lost.push_back(f);
      p.object_masks[std::size_t(f)].assign(pixel_count, 0);
      continue;
    }
    p.object_masks[std::size_t(f)].assign(pixel_count, 0);
    for (size_t i = 0; i < fparts.size(); ++i) {
      const double near = std::min((centres[i] - predicted).norm(), (centres[i] - centres[std::size_t(best)]).norm());
      if (int(i) != best && near > 0.6 * scan_extent) continue;
      for (int pixel : fparts[i].pixels) p.object_masks[std::size_t(f)][std::size_t(pixel)] = 1;
      p.object_pixels[std::size_t(f)] += int(fparts[i].pixels.size());
    }
    RigidPose start = last_pose;
    start.translation += predicted - last_centre;
    const std::vector<Eigen::Vector3d> pts =
        object_points_world(rec.frames[std::size_t(f)], k, p.object_masks[std::size_t(f)], p.camera_to_world);
    IcpResult icp = icp_point_to_plane(p.scan, pts, start, 0.2 * scan_extent, huber, 40);
    icp = icp_point_to_plane(p.scan, pts, icp.pose, std::max(0.03 * scan_extent, 5 * huber), huber, 40);
    if (icp.matched < int(0.8 * pts.size()) || icp.rms > std::max(1.5 * p.icp_rms[0], huber)) {
      // Lost track (a bounce turns the motion round within a frame): register this frame afresh.
      CameraView frame_view = view;
      frame_view.depth = &rec.frames[std::size_t(f)];
      const RegistrationResult again = register_scan(p.scan, pts, frame_view, huber);
      if (again.icp.matched > icp.matched || (again.icp.matched == icp.matched && again.icp.rms < icp.rms)) icp = again.icp;
    }
    p.poses[std::size_t(f)] = icp.pose;
    p.icp_rms[std::size_t(f)] = icp.rms;
    const Eigen::Vector3d centre = icp.pose.apply(p.scan.centroid);
    velocity = (centre - last_centre) / dt + 0.5 * g_world * dt;  // at the end of the interval
    last_centre = centre;
    last_pose = icp.pose;
    last_frame = f;
  }
  if (!lost.empty()) {
    std::string list;
    for (size_t i = 0; i < lost.size() && i < 10; ++i) list += (i ? ", " : "") + std::to_string(lost[i]);
    warn("object_lost", fmt::format("{}: the object was not found in {} of {} frames ({}{}); those frames are empty "
                                    "in the observations", where, lost.size(), frames, list, lost.size() > 10 ? ", ..." : ""));
  }

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
    times.push_back(p.timing.frame_index[std::size_t(f)] * frame_dt);
  }
  p.velocity = estimate_velocity(flight, times, p.scan.centroid, gravity);
  if (p.velocity.frames < 2)
    warn("no_initial_velocity", fmt::format("{}: the object is in free flight in fewer than 2 frames: the initial "
                                            "velocity is set to 0; fit it (--fit youngs_modulus,initial.linear_velocity)",
                                            where));

  // Contact planes: the support, and every other plane the object comes within its size of.
  for (size_t i = 0; i < p.planes.size(); ++i) {
    PreparedPlane& plane = p.planes[i];
    if (plane.support) {
      plane.contact = true;
      continue;
    }
    for (int f = 0; f < frames && !plane.contact; ++f) {
      if (!p.poses[std::size_t(f)]) continue;
      const Eigen::Vector3d c = p.poses[std::size_t(f)]->apply(p.scan.centroid);
      const Eigen::Vector3d c_cam = R.transpose() * (c - t);
      const double d = plane.camera.distance(c_cam);
      if (std::abs(d) > scan_extent) continue;
      if (distance_to_inliers(c_cam - d * plane.camera.normal, plane.pixels, search_image, k) < scan_extent)
        plane.contact = true;
    }
  }
  // World normals point to the side the object is on.
  for (PreparedPlane& plane : p.planes) {
    const Eigen::Vector3d c = p.poses[0]->apply(p.scan.centroid);
    if (plane.normal.dot(c) - plane.height < 0) {
      plane.normal = -plane.normal;
      plane.height = -plane.height;
    }
  }
  int contacts = 0;
  for (PreparedPlane& plane : p.planes)
    if (plane.contact && ++contacts > 8) plane.contact = false;  // the scene holds up to 8

  // Mass.
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

  p.observations = prepared_observations(p, o);
  p.scene = prepared_scene(p, o, scan_file_name(o.mesh));
  p.summary = prepared_summary(p, o);
  return p;
}

}  // namespace ssc
