// A raw depth recording made in the tests, as an RGB-D camera would record it: an object
// thrown onto a table, simulated by ssc (the truth), in a room with a floor, a back wall and
// clutter boxes, rendered with ssc's ray caster and a sensor model (axial noise growing with
// depth squared, holes at grazing incidence, random dropout, flying pixels, millimetre
// quantisation), and written in Open3D's or TUM's layout. The object is the scan moved by the
// simulated displacement field. Beside it: the truth (the scene, the camera, the planes) and the
// clean ssc-format observations of the object alone.
#pragma once
#include <Eigen/Geometry>
#include <fmt/format.h>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <random>
#include <string>

#include "models/geometry/mesh.h"
#include "models/io/output_dir.h"
#include "models/observation/depth_render.h"
#include "models/observation/observation_set.h"
#include "models/observation/room_meshes.h"
#include "models/observation/sensor_model.h"
#include "models/sim/body.h"
#include "models/sim/scene.h"
#include "models/sim/simulation.h"

namespace ssc {

struct SyntheticRecordingSpec {
  std::string layout = "open3d";  // open3d | tum
  int width = 400, height = 300;
  double fov_y_deg = 55;
  Eigen::Vector3d eye{0.25, 0.62, 0.85}, target{0, 0.05, 0};
  double fps = 30;
  int frames = 14;
  DepthSensorModel sensor;
  bool clutter = true;
  bool hand = false;              // a box of the object's size moving in at the image's left border
  double youngs_modulus = 3e4, density = 300;
  Eigen::Vector3d position{0.02, 0.12, 0.0}, rotation_deg{8, 35, -6};
  Eigen::Vector3d velocity{-0.35, 0.5, 0.25}, angular_velocity{0.5, 3.0, 1.5};
  int resolution = 14;
  std::string mesh;               // the object (default: the Stanford bunny of tests/data)
  double scan_scale = 1;          // the scan written beside the recording is this many times too large
  std::uint64_t seed = 5;
};

struct SyntheticRecording {
  std::string folder, scan, scene_file, clean_observations;
  DepthCamera camera;             // the truth, world frame of the scene (table top at y = 0)
  nlohmann::json scene;
  double floor_height = -0.75, wall_z = -1.2;
  int substeps = 7;
};

inline std::string synthetic_bunny() { return std::string(SSC_TEST_DATA_DIR) + "/bun_zipper_res3.ply"; }

inline TriangleSoup synthetic_room(const SyntheticRecording& r, bool clutter) {
  TriangleSoup room;
  room.add_box({0, -0.02, 0}, {0.8, 0.02, 0.6});  // table top, its upper face at y = 0
  room.add_rectangle({-3, r.floor_height, -3}, {6, 0, 0}, {0, 0, 6});
  room.add_rectangle({-3, -1, r.wall_z}, {6, 0, 0}, {0, 3, 0});
  if (clutter) {
    room.add_box({-0.4, 0.06, -0.3}, {0.08, 0.06, 0.05},
                 Eigen::AngleAxisd(0.35, Eigen::Vector3d::UnitY()).toRotationMatrix());
    room.add_box({0.45, 0.1, -0.4}, {0.05, 0.1, 0.05});
    room.add_box({-0.6, 0.03, 0.35}, {0.05, 0.03, 0.12});
  }
  return room;
}

// Writes the recording into `folder` (created), the truth scene (scene.json, with the scan
// path absolute) beside it, and clean ssc-format observations of the object alone.
inline SyntheticRecording make_synthetic_recording(const std::string& folder, const SyntheticRecordingSpec& s) {
  namespace fs = std::filesystem;
  SyntheticRecording r;
  r.folder = (fs::path(folder) / "recording").string();
  fs::create_directories(r.folder);
  r.substeps = int(std::ceil(1.0 / s.fps / 0.005 - 1e-9));
  const double frame_dt = 1.0 / s.fps;
  const std::string mesh_file = s.mesh.empty() ? synthetic_bunny() : s.mesh;
  r.scene = {{"object", {{"mesh", mesh_file}, {"position", {s.position.x(), s.position.y(), s.position.z()}},
                         {"rotation_deg", {s.rotation_deg.x(), s.rotation_deg.y(), s.rotation_deg.z()}}}},
             // On the world's grid whatever the default: the wrong-gravity case of
             // PrepareCli.ErrorsWriteNothing depends on the motion's details.
             {"grid", {{"resolution", s.resolution}, {"frame", "world"}}},
             {"material", {{"youngs_modulus", s.youngs_modulus}, {"poisson_ratio", 0.4}, {"density", s.density},
                           {"mass_damping", 0.1}, {"stiffness_damping", 0.001}}},
             {"gravity", {0, -9.81, 0}},
             {"initial", {{"linear_velocity", {s.velocity.x(), s.velocity.y(), s.velocity.z()}},
                          {"angular_velocity", {s.angular_velocity.x(), s.angular_velocity.y(), s.angular_velocity.z()}}}},
             {"ground", {{"stiffness", 1e6}, {"softmin_alpha", 500}, {"planes", {{{"normal", {0, 1, 0}}, {"height", 0}}}}}},
             {"time", {{"dt", frame_dt / r.substeps}, {"steps", (s.frames - 1) * r.substeps}, {"theta", 0.6}}},
             {"solver", {{"contact", "implicit"}}}};
  r.scene_file = (fs::path(folder) / "truth.json").string();
  std::ofstream(r.scene_file) << r.scene.dump(2);
  const Scene scene = parse_scene(r.scene, r.scene_file);
  const SimGrid grid = build_body_grid(scene);
  r.camera = make_look_at_camera("synthetic", s.width, s.height, s.fov_y_deg, s.eye, s.target, Eigen::Vector3d::UnitY());
  r.camera.min_depth = 0.2;
  r.camera.max_depth = 8;
  const TriangleSoup room = synthetic_room(r, s.clutter);

  Simulation sim(scene, grid);
  // The object is the scan itself, moved by the simulated displacement field (trilinear in the
  // grid's cells), as a real object is: not the grid's own coarser surface, which a scan
  // registered to it would only approximate.
  const TriangleMesh object_mesh = load_mesh(mesh_file);
  std::vector<Eigen::Vector3d> rest;  // in the grid's frame (its pose places them at the start)
  for (const Eigen::Vector3d& v : object_mesh.vertices) rest.push_back(grid.pose.rest(scene.object.transform.apply(v)));
  std::vector<std::array<int, 3>> object_triangles;
  for (const Eigen::Vector3i& t : object_mesh.faces) object_triangles.push_back({t.x(), t.y(), t.z()});
  // Each vertex's cell and place in it (a vertex in a cell the grid left out moves as its
  // nearest placed neighbour has moved since the start).
  std::vector<int> vertex_cell(rest.size(), -1);
  std::vector<Eigen::Vector3d> vertex_local(rest.size());
  for (size_t i = 0; i < rest.size(); ++i) vertex_cell[i] = find_cell(grid, rest[i], &vertex_local[i]);
  std::vector<size_t> stand_in(rest.size());
  for (size_t i = 0; i < rest.size(); ++i) {
    stand_in[i] = i;
    double best = 1e300;
    for (size_t j = 0; j < rest.size() && vertex_cell[i] < 0; ++j)
      if (vertex_cell[j] >= 0 && (rest[j] - rest[i]).squaredNorm() < best) best = (rest[j] - rest[i]).squaredNorm(), stand_in[i] = j;
  }
  auto moved = [&]() {
    const double* u = sim.displacement(0);
    std::vector<Eigen::Vector3d> out(rest.size());
    for (size_t i = 0; i < rest.size(); ++i) {
      const size_t j = stand_in[i];
      Eigen::Vector3d d = Eigen::Vector3d::Zero();
      for (int c = 0; c < 8; ++c) {
        double w = 1;
        for (int a = 0; a < 3; ++a) w *= ((c >> a) & 1) ? vertex_local[j][a] : 1 - vertex_local[j][a];
        const int n = grid.cell_nodes[std::size_t(8 * vertex_cell[j] + c)];
        d += w * Eigen::Vector3d(u[3 * n], u[3 * n + 1], u[3 * n + 2]);
      }
      // rest + d is where vertex j is now; a stand-in moves by j's motion since the start.
      out[i] = grid.start(rest[i]) + (rest[j] + d - grid.start(rest[j]));
    }
    return out;
  };
  ObservationSet clean;
  clean.dt = frame_dt;
  clean.depth_scale = 1e-4;
  clean.cameras = {r.camera};
  clean.frame_count = s.frames;
  std::mt19937_64 jitter(s.seed);
  std::uniform_real_distribution<double> ms(-0.002, 0.002);
  std::ofstream depth_txt;
  if (s.layout == "tum") {
    depth_txt.open(fs::path(r.folder) / "depth.txt");
    depth_txt << "# depth maps\n# file: 'synthetic'\n# timestamp filename\n";
    fs::create_directories(fs::path(r.folder) / "depth");
  } else {
    fs::create_directories(fs::path(r.folder) / "depth");
    const double k[9] = {r.camera.fx, 0, 0, 0, r.camera.fy, 0, r.camera.cx, r.camera.cy, 1};
    std::ofstream(fs::path(r.folder) / "intrinsic.json")
        << nlohmann::json{{"width", s.width}, {"height", s.height}, {"intrinsic_matrix", std::vector<double>(k, k + 9)}}.dump(2);
  }
  for (int f = 0; f < s.frames; ++f) {
    while (sim.steps_taken() < f * r.substeps) sim.step();
    const std::vector<Eigen::Vector3d> body = moved();
    TriangleSoup frame = room;
    frame.append(body, object_triangles);
    if (s.hand) {  // at the left border, 0.7 m from the camera, drifting into the view
      const Eigen::Vector3d at = unproject(r.camera, 6 + 1.5 * f, 0.45 * s.height, 0.7);
      frame.add_box(at, {0.04, 0.06, 0.03}, Eigen::AngleAxisd(0.2 * f, Eigen::Vector3d::UnitZ()).toRotationMatrix());
    }
    const DepthImage exact = render_depth(r.camera, TriangleBvh(frame.vertices, frame.triangles), 0, 0);
    const DepthImage raw = apply_sensor_model(exact, r.camera, s.sensor, mix_seed(s.seed, std::uint64_t(f)));
    if (s.layout == "tum") {
      const double t = 1305031100.0 + f * frame_dt + ms(jitter);
      const std::string name = fmt::format("depth/{:.6f}.png", t);
      write_depth_png((fs::path(r.folder) / name).string(), raw, 1.0 / 5000);
      depth_txt << fmt::format("{:.6f} {}\n", t, name);
    } else {
      write_depth_png((fs::path(r.folder) / fmt::format("depth/{:06d}.png", f)).string(), raw, 0.001);
    }
    clean.frames.push_back({render_depth(r.camera, TriangleBvh(body, object_triangles), 0, 0)});
    clean.frame_times.push_back(f * frame_dt);
  }
  r.clean_observations = (fs::path(folder) / "clean").string();
  write_observations(r.clean_observations, clean);
  // The scan, in its own frame (optionally in the wrong unit).
  r.scan = (fs::path(folder) / ("scan" + fs::path(mesh_file).extension().string())).string();
  if (s.scan_scale == 1) {
    fs::copy_file(mesh_file, r.scan, fs::copy_options::overwrite_existing);
  } else {
    r.scan = (fs::path(folder) / "scan.ply").string();
    const TriangleMesh mesh = load_mesh(mesh_file);
    std::ofstream out(r.scan);
    out << "ply\nformat ascii 1.0\nelement vertex " << mesh.vertices.size() << "\nproperty float x\nproperty float y\n"
        << "property float z\nelement face " << mesh.faces.size() << "\nproperty list uchar int vertex_indices\nend_header\n";
    for (const auto& v : mesh.vertices) out << v.x() * s.scan_scale << " " << v.y() * s.scan_scale << " " << v.z() * s.scan_scale << "\n";
    for (const auto& f : mesh.faces) out << "3 " << f.x() << " " << f.y() << " " << f.z() << "\n";
  }
  return r;
}

}  // namespace ssc
