// A raw depth recording of data made by another code than ssc's physics: the CalculiX drop of
// tests/data/calculix_drops/clean (a 0.2 m cube, E = 50 kPa, dropped onto a frictionless 20
// degree incline, ccx 2.20), its surface frames rendered as an Open3D recording (60 frames per
// second, 320x240) with the incline, a back wall and a clutter box, through the sensor model of
// the synthetic recordings (tests/synthetic_recording.h). Beside it: the cube as a scan and the
// truth (the camera, the incline, the accelerometer's reading at rest).
#pragma once
#include <Eigen/Geometry>
#include <fmt/format.h>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>

#include "models/geometry/mesh.h"
#include "models/observation/depth_render.h"
#include "models/observation/room_meshes.h"
#include "models/observation/sensor_model.h"

namespace ssc {

struct CalculixRecording {
  std::string folder, scan;        // the Open3D recording; the cube (0.2 m, OBJ)
  std::string data = std::string(SSC_TEST_DATA_DIR) + "/calculix_drops/clean";
  DepthCamera camera;              // the truth, in the ccx world (y up, the incline through the origin)
  DepthSensorModel sensor;
  Eigen::Vector3d incline_normal;  // world
  Eigen::Vector3d gravity_camera;  // the accelerometer at rest, camera frame (points up)
  Eigen::Vector3d initial_velocity{0.3, -1.5, 0};  // world, ccx's (tools/calculix/drops.py, case clean)
  double fps = 60, youngs_modulus = 5e4;
  int frames = 13;
};

inline CalculixRecording make_calculix_recording(const std::filesystem::path& dir) {
  namespace fs = std::filesystem;
  CalculixRecording r;
  const fs::path rec = dir / "recording";
  r.folder = rec.string();
  fs::create_directories(rec / "depth");
  r.camera = make_look_at_camera("ccx", 320, 240, 45, {0.55, 0.55, 1.1}, {0.2, 0.05, 0}, Eigen::Vector3d::UnitY());
  r.camera.min_depth = 0.2, r.camera.max_depth = 8;
  const double polar = 20 * M_PI / 180;
  r.incline_normal = Eigen::Vector3d(std::sin(polar), std::cos(polar), 0);  // the incline through the origin
  const Eigen::Vector3d downhill(std::cos(polar), -std::sin(polar), 0);
  TriangleSoup room;
  room.add_rectangle(-1.5 * downhill + Eigen::Vector3d(0, 0, -0.8), 3 * downhill, {0, 0, 1.6});
  room.add_rectangle({-3, -2, -1.0}, {6, 0, 0}, {0, 4, 0});                                  // a back wall
  room.add_box(Eigen::Vector3d(-0.3, 0, -0.45) + 0.06 * r.incline_normal, {0.06, 0.06, 0.06});  // clutter on the incline
  const DepthCamera& cam = r.camera;
  const double k[9] = {cam.fx, 0, 0, 0, cam.fy, 0, cam.cx, cam.cy, 1};
  std::ofstream(rec / "intrinsic.json")
      << nlohmann::json{{"width", cam.width}, {"height", cam.height}, {"intrinsic_matrix", std::vector<double>(k, k + 9)}}.dump();
  for (int f = 0; f < r.frames; ++f) {
    const TriangleMesh body = load_mesh(r.data + fmt::format("/frames/frame_{:04d}.ply", f));
    std::vector<std::array<int, 3>> tris;
    for (const Eigen::Vector3i& t : body.faces) tris.push_back({t.x(), t.y(), t.z()});
    TriangleSoup frame = room;
    frame.append(body.vertices, tris);
    const DepthImage exact = render_depth(cam, TriangleBvh(frame.vertices, frame.triangles), 0, 0);
    write_depth_png((rec / fmt::format("depth/{:06d}.png", f)).string(),
                    apply_sensor_model(exact, cam, r.sensor, 77 + std::uint64_t(f)), 0.001);
  }
  r.scan = (dir / "cube.obj").string();
  std::ofstream c(r.scan);
  for (int i = 0; i < 8; ++i)
    c << "v " << ((i & 1) ? 0.1 : -0.1) << " " << ((i & 2) ? 0.1 : -0.1) << " " << ((i & 4) ? 0.1 : -0.1) << "\n";
  c << "f 1 3 4 2\nf 5 6 8 7\nf 1 2 6 5\nf 3 7 8 4\nf 1 5 7 3\nf 2 4 8 6\n";
  r.gravity_camera = cam.camera_to_world.topLeftCorner<3, 3>().transpose() * Eigen::Vector3d(0, 9.81, 0);
  return r;
}

}  // namespace ssc
