// A scene: the rest shape, the grid, the material, initial and boundary conditions and
// the time stepping, in SI units, read strictly from a JSON file (docs/scene-format.md).
#pragma once
#include <Eigen/Core>
#include <nlohmann/json.hpp>
#include <map>
#include <string>
#include <vector>

#include "models/geometry/primitives.h"
#include "models/geometry/transform.h"
#include "models/grid/sim_grid.h"

namespace ssc {

struct ObjectSpec {
  enum class Kind { Primitive, SdfFile, Mesh } kind = Kind::Primitive;
  Primitive primitive;  // kind == Primitive
  std::string path;     // kind == SdfFile or Mesh, resolved against the scene's folder
  Transform transform;  // position, rotation_deg, scale
};

// A part of the body with its own Young's modulus (the heterogeneous_stiffness extension,
// ops/stiffness_field.h): the rest points x with normal . x >= offset, or a box.
struct MaterialRegion {
  enum class Kind { HalfSpace, Box } kind = Kind::HalfSpace;
  Eigen::Vector3d normal{1, 0, 0};  // unit
  double offset = 0;                // m
  Eigen::Vector3d min = Eigen::Vector3d::Zero(), max = Eigen::Vector3d::Zero();
  double youngs_modulus = 0;        // Pa

  bool contains(const Eigen::Vector3d& x) const;
};

struct MaterialSpec {
  double youngs_modulus = 5000;  // Pa
  double poisson_ratio = 0.45;
  double density = 100;          // kg/m^3
  double mass_damping = 0.1;     // alpha, 1/s
  double stiffness_damping = 0.01;  // beta, s
  std::vector<MaterialRegion> regions;  // later entries override earlier ones
  Eigen::Vector3d stiffness_gradient = Eigen::Vector3d::Zero();  // g, 1/m: E(x) = E exp(g . (x - c))
  bool stiffness_gradient_key = false;  // the scene gives material.stiffness_gradient
  bool neo_hookean = false;  // material.model: "corotated_linear" (the paper's) or "neo_hookean"
};

struct PlaneSpec {
  Eigen::Vector3d normal{0, 1, 0};  // unit
  double height = 0;                // plane: normal . x = height
  double stiffness = 1e5;           // Pa per metre of penetration
  double softmin_alpha = 100;       // 1/m
  double friction = 0;              // Coulomb coefficient mu (ops/friction.h)
  double friction_velocity = 1e-3;  // m/s: the smoothing velocity eps below which friction is viscous
  // Where `reconstruct` draws the starts of a fitted height from (uniformly), when given.
  std::pair<double, double> height_range{0, 0};
  bool height_range_key = false;
  // The normal's azimuth about +y in degrees. Derived from the normal, except for a vertical
  // normal, which has none: then this value is kept so that setting the azimuth before the
  // polar angle (as an optimiser may) is not lost.
  double azimuth_deg = 0;
};

struct DirichletBox {
  Eigen::Vector3d min, max;  // world, metres
};

struct TimeSpec {
  double dt = 0.01;
  int steps = 40;
  double theta = 0.6;
};

struct SolverSpec {
  double tolerance = 1e-8;
  int max_iterations = 2000;
  double extension_tolerance = 1e-8;
  double energy_tolerance = 0.05;  // energy audit (models/sim/run_audit.h); 0 turns it off
  // The step's nonlinear iterations (ops/contact_implicit.h): contact "linearized" (the
  // paper's) or "implicit" (Newton within the step); corotation "lagged" (the previous step's
  // rotation, the paper's) or "updated" (from the iterate); solves per step when iterating.
  bool implicit_contact = false;
  bool updated_corotation = false;
  int nonlinear_iterations = 4;
  bool line_search = true;  // on the implicit contact's iterations (ops/line_search.h)
};

struct Scene {
  std::string file;       // where it was read from
  std::string directory;  // for relative paths
  ObjectSpec object;
  double cell_size = 0;   // metres (from grid.cell_size or grid.resolution)
  GridOptions grid;
  // grid.frame: "object" (the default) lays a rotated object's grid along its own axes (its
  // position and rotation_deg are the body's initial pose, models/grid/sim_grid.h RestPose);
  // "world" along the world's, which cuts a rotated box's faces.
  bool grid_in_object_frame = true;
  MaterialSpec material;
  Eigen::Vector3d gravity{0, -9.81, 0};
  Eigen::Vector3d linear_velocity = Eigen::Vector3d::Zero();
  Eigen::Vector3d angular_velocity = Eigen::Vector3d::Zero();  // rad/s about the centre of mass
  std::vector<PlaneSpec> planes;                                // empty: no ground
  // Quadratic surface drag, kg/m^3 (ops/air_drag.h); in the model when the key is given.
  double air_drag = 0;
  bool air_drag_key = false;
  // Friction is in the model (the timestep graph has the friction op) when the scene gives
  // a friction key, or a command fits or sweeps a friction coefficient; see models_friction.
  bool friction_keys = false;
  std::vector<std::string> extensions_off;  // switched off in the scene's "extensions" section
  // The scene's "plausible" section: a parameter's plausible range, widened or narrowed from
  // the default (models/sim/extensions.h: plausible_range).
  std::map<std::string, std::pair<double, double>> plausible;
  std::vector<DirichletBox> dirichlet;
  TimeSpec time;
  SolverSpec solver;
  nlohmann::json extra;     // sections read by other commands (observation, ...)
  nlohmann::json resolved;  // the file's JSON with every --set applied (for manifests)
};

// Reads and validates a scene; overrides are "dotted.key=JSON" applied before parsing.
Scene load_scene(const std::string& path, const std::vector<std::string>& overrides = {});
Scene parse_scene(const nlohmann::json& config, const std::string& file);

// Ground normal from polar angle (from +y) and azimuth (about +y, from +x), degrees.
Eigen::Vector3d normal_from_angles(double polar_deg, double azimuth_deg);

// Whether the simulation models friction: a friction key in the scene, or a plane with mu > 0.
bool models_friction(const Scene& scene);

}  // namespace ssc
