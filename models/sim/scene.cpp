// Scene parsing and validation (see scene.h and docs/scene-format.md).
#include "models/sim/scene.h"

#include <fmt/format.h>

#include <cmath>
#include <filesystem>

#include "runtime/errors.h"
#include "models/io/json_reader.h"
#include "models/sim/extensions.h"
#include "models/sim/parameter_table.h"
#include "models/sim/parameters.h"

namespace ssc {
namespace {

constexpr double kPi = 3.14159265358979323846;

Transform read_transform(const JsonReader& r) {
  Transform t;
  t.position = r.vec3("position", Eigen::Vector3d::Zero());
  t.rotation_deg = r.vec3("rotation_deg", Eigen::Vector3d::Zero());
  t.scale = r.positive("scale", r.number("scale", 1.0));
  return t;
}

ObjectSpec read_object(const JsonReader& r, const std::string& directory) {
  ObjectSpec o;
  const int sources = int(r.has("primitive")) + int(r.has("sdf_file")) + int(r.has("mesh"));
  if (sources != 1)
    r.fail("", "must name exactly one of 'primitive' (sphere, box, torus, capsule), 'sdf_file' or 'mesh'");
  o.transform = read_transform(r);
  if (r.has("primitive")) {
    o.kind = ObjectSpec::Kind::Primitive;
    try {
      o.primitive.type = parse_primitive_type(r.string("primitive"));
    } catch (const InputError& e) {
      r.fail("primitive", e.what());
    }
    Primitive& p = o.primitive;
    switch (p.type) {
      case PrimitiveType::Sphere:
        p.radius = r.positive("radius", r.number("radius"));
        break;
      case PrimitiveType::Box: {
        p.half_extents = r.vec3("half_extents");
        r.require(p.half_extents.minCoeff() > 0, "half_extents", "must be positive");
        break;
      }
      case PrimitiveType::Torus:
        p.major_radius = r.positive("major_radius", r.number("major_radius"));
        p.minor_radius = r.positive("minor_radius", r.number("minor_radius"));
        r.require(p.minor_radius < p.major_radius, "minor_radius", "must be smaller than major_radius");
        break;
      case PrimitiveType::Capsule:
        p.radius = r.positive("radius", r.number("radius"));
        p.half_length = r.non_negative("half_length", r.number("half_length"));
        break;
    }
    p.transform = o.transform;
  } else {
    const bool sdf = r.has("sdf_file");
    o.kind = sdf ? ObjectSpec::Kind::SdfFile : ObjectSpec::Kind::Mesh;
    const std::string rel = r.string(sdf ? "sdf_file" : "mesh");
    const std::filesystem::path p(rel);
    o.path = p.is_absolute() ? rel : (std::filesystem::path(directory) / p).lexically_normal().string();
    if (!std::filesystem::exists(o.path))
      r.fail(sdf ? "sdf_file" : "mesh", fmt::format("names '{}', which does not exist (paths are relative to the scene file)", o.path));
    if (std::filesystem::is_directory(o.path))
      r.fail(sdf ? "sdf_file" : "mesh", fmt::format("names '{}', which is a folder; give the file", o.path));
    if (sdf && o.transform.rotation_deg.norm() != 0)
      r.fail("rotation_deg", "is not supported for sdf_file objects (the grid is given by the file); rotate the source instead");
  }
  r.reject_unknown_keys();
  return o;
}

PlaneSpec read_plane(const JsonReader& r, const PlaneSpec& defaults) {
  PlaneSpec p = defaults;
  if (r.has("normal") && r.has("angles_deg")) r.fail("normal", "and angles_deg both given; use one");
  if (r.has("normal")) {
    const Eigen::Vector3d n = r.vec3("normal");
    r.require(n.norm() > 1e-12, "normal", "must not be the zero vector");
    p.normal = n.normalized();
  } else if (r.has("angles_deg")) {
    const std::vector<double> a = r.numbers("angles_deg");
    r.require(a.size() == 2, "angles_deg", "must be [polar, azimuth] in degrees (polar 0 = normal +y)");
    p.normal = normal_from_angles(a[0], a[1]);
    p.azimuth_deg = a[1];
  }
  p.height = r.number("height", p.height);
  p.stiffness = r.non_negative("stiffness", r.number("stiffness", p.stiffness));
  p.softmin_alpha = r.positive("softmin_alpha", r.number("softmin_alpha", p.softmin_alpha));
  p.friction = r.non_negative("friction", r.number("friction", p.friction));
  p.friction_velocity = r.positive("friction_velocity", r.number("friction_velocity", p.friction_velocity));
  if (r.has("height_range")) {
    const std::vector<double> range = r.numbers("height_range");
    r.require(range.size() == 2 && range[0] < range[1], "height_range",
              "must be [low, high] in metres with low < high (where reconstruct draws a fitted height's starts)");
    p.height_range = {range[0], range[1]};
    p.height_range_key = true;
  }
  return p;
}

void read_ground(const JsonReader& r, Scene& s) {
  if (!r.boolean("enabled", true)) {
    // A disabled ground may keep its settings; they are accepted and ignored.
    for (const char* key : {"height", "normal", "angles_deg", "stiffness", "softmin_alpha", "friction",
                            "friction_velocity", "height_range", "planes"})
      r.has(key);
    r.reject_unknown_keys();
    return;
  }
  const PlaneSpec first = read_plane(r, PlaneSpec{});
  s.friction_keys = r.has("friction") || r.has("friction_velocity");
  if (r.has("planes")) {
    PlaneSpec defaults = first;
    for (const JsonReader& pr : r.array_of_objects("planes")) {
      s.friction_keys = s.friction_keys || pr.has("friction") || pr.has("friction_velocity");
      s.planes.push_back(read_plane(pr, defaults));
      pr.reject_unknown_keys();
    }
    r.require(!s.planes.empty() && s.planes.size() <= 8, "planes", "must hold 1 to 8 planes");
  } else {
    s.planes.push_back(first);
  }
  r.reject_unknown_keys();
}

MaterialRegion read_region(const JsonReader& r) {
  MaterialRegion g;
  const bool half_space = r.has("normal") || r.has("offset");
  const bool box = r.has("min") || r.has("max");
  if (half_space == box)
    r.fail("", "must be a half-space (normal, offset: the rest points x with normal . x >= offset) or a box (min, max), "
               "each with its youngs_modulus");
  if (half_space) {
    const Eigen::Vector3d n = r.vec3("normal");
    r.require(n.norm() > 1e-12, "normal", "must not be the zero vector");
    g.normal = n.normalized();
    g.offset = r.number("offset");
  } else {
    g.kind = MaterialRegion::Kind::Box;
    g.min = r.vec3("min");
    g.max = r.vec3("max");
    r.require((g.max - g.min).minCoeff() >= 0, "max", "must not be below min in any axis");
  }
  g.youngs_modulus = r.positive("youngs_modulus", r.number("youngs_modulus"));
  r.reject_unknown_keys();
  return g;
}

void read_material(const JsonReader& m, MaterialSpec& mat) {
  mat.youngs_modulus = m.positive("youngs_modulus", m.number("youngs_modulus", mat.youngs_modulus));
  mat.poisson_ratio = m.number("poisson_ratio", mat.poisson_ratio);
  m.require(mat.poisson_ratio >= 0 && mat.poisson_ratio < 0.5, "poisson_ratio",
            fmt::format("must be in [0, 0.5), found {}", mat.poisson_ratio));
  mat.density = m.positive("density", m.number("density", mat.density));
  mat.mass_damping = m.non_negative("mass_damping", m.number("mass_damping", mat.mass_damping));
  mat.stiffness_damping = m.non_negative("stiffness_damping", m.number("stiffness_damping", mat.stiffness_damping));
  if (m.has("regions"))
    for (const JsonReader& g : m.array_of_objects("regions")) mat.regions.push_back(read_region(g));
  m.require(mat.regions.size() <= 64, "regions", "must hold at most 64 regions");
  const std::string model = m.string("model", "corotated_linear");
  m.require(model == "corotated_linear" || model == "neo_hookean", "model",
            "must be \"corotated_linear\" (the paper's) or \"neo_hookean\" (compressible, the same small-strain "
            "Young's modulus and Poisson ratio)");
  mat.neo_hookean = model == "neo_hookean";
  mat.stiffness_gradient_key = m.has("stiffness_gradient");
  mat.stiffness_gradient = m.vec3("stiffness_gradient", mat.stiffness_gradient);
  m.reject_unknown_keys();
}

// The "extensions" section: name -> false switches an extension off (its keys stay valid).
void read_extensions(const JsonReader& r, Scene& s) {
  for (const std::string& name : extension_names())
    if (!r.boolean(name, true)) s.extensions_off.push_back(name);
  r.reject_unknown_keys();
}

// The "plausible" section: parameter name -> [lower, upper] (docs/scene-format.md).
void read_plausible(const nlohmann::json& section, const JsonReader& r, Scene& s) {
  const JsonReader p = r.child("plausible");
  for (const auto& item : section.items()) {
    const std::string& name = item.key();
    const std::vector<double> range = p.numbers(name);
    p.require(range.size() == 2 && range[0] < range[1], name, "must be [lower, upper] with lower < upper");
    try {
      parameter_row(name);
    } catch (const InputError&) {
      p.fail(name, "is not a parameter name (see docs/scene-format.md, Parameters)");
    }
    s.plausible[name] = {range[0], range[1]};
  }
  p.reject_unknown_keys();
}

void read_grid(const JsonReader& r, Scene& s) {
  if (r.has("cell_size") == r.has("resolution") && s.object.kind != ObjectSpec::Kind::SdfFile)
    r.fail("", "must give exactly one of cell_size (metres) or resolution (cells across the object's longest side)");
  if (r.has("cell_size")) s.cell_size = r.positive("cell_size", r.number("cell_size"));
  if (r.has("resolution")) {
    const int res = r.integer("resolution");
    r.require(res >= 2 && res <= 300, "resolution", "must be between 2 and 300 cells");
    s.cell_size = -res;  // resolved against the object's size when the body is built
  }
  if (s.object.kind == ObjectSpec::Kind::SdfFile && s.cell_size != 0)
    r.fail(r.has("cell_size") ? "cell_size" : "resolution", "cannot be set for an sdf_file object: its grid is the file's");
  const std::string frame = r.string("frame", "object");
  r.require(frame == "object" || frame == "world", "frame",
            "must be \"object\" (the grid along the object's own axes) or \"world\" (along the world's)");
  s.grid_in_object_frame = frame == "object";
  s.grid.band_width = r.integer("band_width", s.grid.band_width);
  s.grid.zero_cutoff = r.non_negative("zero_cutoff", r.number("zero_cutoff", s.grid.zero_cutoff));
  r.require(s.grid.zero_cutoff < 0.5, "zero_cutoff", "must be below 0.5 (it is a fraction of the cell size)");
  s.grid.integration_subdivisions = r.integer("integration_subdivisions", s.grid.integration_subdivisions);
  r.require(s.grid.integration_subdivisions >= 1 && s.grid.integration_subdivisions <= 32, "integration_subdivisions",
            "must be between 1 and 32");
  s.grid.contact_subdivisions = r.integer("contact_subdivisions", s.grid.contact_subdivisions);
  r.require(s.grid.contact_subdivisions >= 1 && s.grid.contact_subdivisions <= 8, "contact_subdivisions",
            "must be between 1 and 8");
  s.grid.min_node_volume = r.non_negative("min_node_volume", r.number("min_node_volume", s.grid.min_node_volume));
  r.reject_unknown_keys();
}

}  // namespace

bool MaterialRegion::contains(const Eigen::Vector3d& x) const {
  if (kind == Kind::HalfSpace) return normal.dot(x) >= offset;
  return (x - min).minCoeff() >= 0 && (max - x).minCoeff() >= 0;
}

Eigen::Vector3d normal_from_angles(double polar_deg, double azimuth_deg) {
  const double p = polar_deg * kPi / 180.0, a = azimuth_deg * kPi / 180.0;
  return {std::sin(p) * std::cos(a), std::cos(p), std::sin(p) * std::sin(a)};
}

Scene parse_scene(const nlohmann::json& config, const std::string& file) {
  Scene s;
  s.file = file;
  s.directory = std::filesystem::path(file).parent_path().string();
  JsonReader r(config, file, "");
  s.object = read_object(r.child("object"), s.directory);
  if (r.has("grid")) {
    read_grid(r.child("grid"), s);
  } else if (s.object.kind != ObjectSpec::Kind::SdfFile) {
    r.fail("grid", "is missing: give grid.cell_size (metres) or grid.resolution (cells across the object)");
  }
  if (r.has("material")) read_material(r.child("material"), s.material);
  s.gravity = r.vec3("gravity", s.gravity);
  s.air_drag_key = r.has("air_drag");
  s.air_drag = r.non_negative("air_drag", r.number("air_drag", s.air_drag));
  if (r.has("initial")) {
    const JsonReader i = r.child("initial");
    s.linear_velocity = i.vec3("linear_velocity", s.linear_velocity);
    s.angular_velocity = i.vec3("angular_velocity", s.angular_velocity);
    i.reject_unknown_keys();
  }
  if (r.has("ground")) read_ground(r.child("ground"), s);
  if (r.has("dirichlet")) {
    for (const JsonReader& d : r.array_of_objects("dirichlet")) {
      DirichletBox box;
      if (d.has("center") || d.has("half_size")) {
        const Eigen::Vector3d c = d.vec3("center"), hs = d.vec3("half_size");
        d.require(hs.minCoeff() >= 0, "half_size", "must not be negative");
        box.min = c - hs;
        box.max = c + hs;
      } else {
        box.min = d.vec3("min");
        box.max = d.vec3("max");
        d.require((box.max - box.min).minCoeff() >= 0, "max", "must not be below min in any axis");
      }
      d.reject_unknown_keys();
      s.dirichlet.push_back(box);
    }
  }
  if (r.has("time")) {
    const JsonReader t = r.child("time");
    s.time.dt = t.positive("dt", t.number("dt", s.time.dt));
    s.time.steps = t.integer("steps", s.time.steps);
    t.require(s.time.steps >= 0 && s.time.steps <= 1000000, "steps", "must be between 0 and 1000000");
    s.time.theta = t.number("theta", s.time.theta);
    t.require(s.time.theta >= 0.5 && s.time.theta <= 1.0, "theta", "must be in [0.5, 1] (0.5 is undamped, 1 implicit Euler)");
    t.reject_unknown_keys();
  }
  if (r.has("solver")) {
    const JsonReader v = r.child("solver");
    s.solver.tolerance = v.positive("tolerance", v.number("tolerance", s.solver.tolerance));
    v.require(s.solver.tolerance < 1, "tolerance", "must be below 1 (it is a relative residual)");
    s.solver.max_iterations = v.integer("max_iterations", s.solver.max_iterations);
    v.require(s.solver.max_iterations > 0, "max_iterations", "must be positive");
    s.solver.extension_tolerance = v.positive("extension_tolerance", v.number("extension_tolerance", s.solver.extension_tolerance));
    s.solver.energy_tolerance = v.non_negative("energy_tolerance", v.number("energy_tolerance", s.solver.energy_tolerance));
    const std::string contact = v.string("contact", "linearized");
    v.require(contact == "linearized" || contact == "implicit", "contact",
              "must be \"linearized\" (the paper's prediction from the start of the step) or \"implicit\" (Newton "
              "iterations within the step; for stiff grounds)");
    s.solver.implicit_contact = contact == "implicit";
    const std::string corotation = v.string("corotation", "lagged");
    v.require(corotation == "lagged" || corotation == "updated", "corotation",
              "must be \"lagged\" (the previous step's rotation) or \"updated\" (the rotation of the iterate)");
    s.solver.updated_corotation = corotation == "updated";
    s.solver.nonlinear_iterations = v.integer("nonlinear_iterations", s.solver.nonlinear_iterations);
    v.require(s.solver.nonlinear_iterations >= 1 && s.solver.nonlinear_iterations <= 50, "nonlinear_iterations",
              "must be between 1 and 50");
    s.solver.line_search = v.boolean("line_search", s.solver.line_search);
    v.reject_unknown_keys();
  }
  if (r.has("extensions")) read_extensions(r.child("extensions"), s);
  if (r.has("plausible")) read_plausible(config.at("plausible"), r, s);
  switch_off_extensions(s);
  for (const char* section : {"observation", "units", "name", "description"})
    if (r.has(section)) s.extra[section] = config.at(section);
  r.reject_unknown_keys();
  return s;
}

Scene load_scene(const std::string& path, const std::vector<std::string>& overrides) {
  nlohmann::json config = read_json_file(path);
  for (const std::string& o : overrides) {
    // A parameter name (youngs_modulus, gravity.y, ...) is written under its scene key.
    const size_t eq = o.find('=');
    if (eq != std::string::npos && eq > 0) {
      nlohmann::json value;
      try {
        value = nlohmann::json::parse(o.substr(eq + 1));
      } catch (const nlohmann::json::exception&) {
        value = nullptr;
      }
      if (value.is_number() && apply_parameter_override(config, o.substr(0, eq), value, path)) continue;
    }
    apply_override(config, o, path);
  }
  Scene scene = parse_scene(config, path);
  scene.resolved = config;
  return scene;
}

bool models_friction(const Scene& scene) {
  if (scene.planes.empty()) return false;
  if (scene.friction_keys) return true;
  for (const PlaneSpec& p : scene.planes)
    if (p.friction > 0) return true;
  return false;
}

}  // namespace ssc
