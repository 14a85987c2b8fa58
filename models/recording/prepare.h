// `ssc prepare`: from a raw depth recording of an object thrown or dropped in a room, and a
// scan of that object, to what `reconstruct` and `diagnose` take (docs/cli.md#prepare):
//
//   1. read the recording (depth_recording.h) and put its timestamps on a regular time axis
//      (frame_timing.h);
//   2. find the room's large planes by RANSAC over the static background (plane_fit.h);
//   3. segment frame 0 (segmentation.h) and pick the part whose size matches the scan
//      (object_selection.h);
//   4. the world frame: up from the accelerometer (--gravity) or the level plane under the
//      object, origin on the plane under the object (scene_planes.h, world_frame.h);
//   5. register the scan to frame 0 (registration.h), track it through the frames
//      (object_tracking.h), and estimate the initial velocity from the first frames of free
//      flight (motion_estimate.h);
//   6. the planes the object can reach become contact planes (scene_planes.h); the scene, the
//      observations (the object's depth only) and prepare.json are made by prepare_output.cpp,
//      the pictures by prepare_pictures.h.
//
// Every failure is an InputError naming what was looked for, what was found and the fix.
#pragma once
#include <Eigen/Core>
#include <functional>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "models/observation/observation_set.h"
#include "models/recording/depth_recording.h"
#include "models/recording/frame_timing.h"
#include "models/recording/motion_estimate.h"
#include "models/recording/plane_fit.h"
#include "models/recording/registration.h"
#include "models/recording/scan_model.h"
#include "models/recording/segmentation.h"

namespace ssc {

struct PrepareOptions {
  std::string recording_folder;
  RecordingOptions recording;
  std::string mesh;                          // the scan
  double scan_scale = 1;                     // metres per scan unit
  std::optional<Eigen::Vector3d> gravity;    // accelerometer reading at rest, camera frame (points up)
  std::optional<double> mass, density;       // kg, kg/m^3
  SensorNoise noise;
  std::optional<Eigen::Vector2d> pick;       // a pixel (u, v) of the object in the first frame
  int resolution = 12;                       // grid cells across the object
  int substeps = 0;                          // simulation steps per frame; 0: dt <= 5 ms
  double youngs_modulus = 1e5, poisson_ratio = 0.4;
  double contact_stiffness = 1e6, softmin_alpha = 500;
  int velocity_frames = 5;                   // frames of free flight the velocity is estimated from
  std::function<void(const std::string&)> stage;  // progress: the stage starting
};

struct PreparedPlane {
  Plane camera;                    // in the camera's frame, normal towards the camera
  Eigen::Vector3d normal{0, 1, 0}; // world, pointing out of the surface (towards the object's side)
  double height = 0;               // world: normal . x = height
  std::vector<int> pixels;         // its inlier pixels (of the plane search's image)
  double rms = 0;                  // m
  bool support = false;            // the plane under the object
  bool contact = false;            // in the scene
};

struct PreparedRecording {
  DepthRecording recording;
  FrameTiming timing;
  Eigen::Vector3d up_camera{0, -1, 0};
  bool gravity_from_plane = false;
  double gravity_magnitude = 9.81;
  Eigen::Matrix4d camera_to_world = Eigen::Matrix4d::Identity();
  std::vector<PreparedPlane> planes;
  int plane_stride = 1;                         // the plane search took every plane_stride-th pixel
  ScanModel scan;
  double density = 0, mass = 0;
  std::vector<PixelClass> first_classes;        // frame 0's pixel classes (for the picture)
  std::vector<std::vector<PixelClass>> picture_classes;  // pixel classes of the first, middle and last frame
  std::vector<std::vector<char>> object_masks;  // per frame
  std::vector<int> object_pixels;               // per frame
  std::vector<std::optional<RigidPose>> poses;  // per frame, world
  std::vector<double> icp_rms;                  // per frame, m (0 where not registered)
  RegistrationResult first_registration;
  RigidVelocity velocity;
  ObservationSet observations;
  nlohmann::json scene;                         // scene.json; the mesh is "scan<ext>" beside it
  nlohmann::json summary;                       // prepare.json
};

PreparedRecording prepare_recording(const PrepareOptions& options);

// Step 2's plane search in one depth image: RANSAC (plane_fit.h) over every stride-th pixel
// (about 40,000 points in all), each point's inlier band the sensor noise at its depth. Planes
// in the camera's frame, largest first, normals towards the camera.
struct ImagePlanes {
  std::vector<DetectedPlane> planes;
  PixelPoints points;  // the points searched; DetectedPlane::inliers index them
  int stride = 1;
};
ImagePlanes find_image_planes(const DepthImage& image, const DepthIntrinsics& k, const SensorNoise& noise,
                              double depth_scale);

// The name the scan gets in the output folder: "scan" with the scan's extension (lower case).
std::string scan_file_name(const std::string& mesh);

// The scene and the observations of a prepared recording (prepare_output.cpp).
nlohmann::json prepared_scene(const PreparedRecording& p, const PrepareOptions& o, const std::string& mesh_name);
ObservationSet prepared_observations(const PreparedRecording& p, const PrepareOptions& o);
nlohmann::json prepared_summary(const PreparedRecording& p, const PrepareOptions& o);

}  // namespace ssc
