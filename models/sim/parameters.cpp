// Named parameters (see parameters.h).
#include "models/sim/parameters.h"

#include <fmt/format.h>

#include <cmath>

#include "models/io/errors.h"
#include "models/sim/scene.h"

namespace ssc {
namespace {

constexpr double kDegree = 3.14159265358979323846 / 180.0;
const char* kAxes[3] = {"x", "y", "z"};

std::string plane_prefix(size_t k) { return k == 0 ? "ground." : fmt::format("ground.planes[{}].", k); }

// Splits a plane parameter name into plane index and field; false if not a plane name.
bool parse_plane_name(const std::string& name, size_t plane_count, size_t* k, std::string* field) {
  for (size_t i = 0; i < plane_count; ++i) {
    const std::string prefix = plane_prefix(i);
    if (name.rfind(prefix, 0) == 0 && (i > 0 || name.find("planes[") == std::string::npos)) {
      *k = i;
      *field = name.substr(prefix.size());
      return *field == "height" || *field == "polar_deg" || *field == "azimuth_deg";
    }
  }
  return false;
}

void plane_angles(const PlaneSpec& plane, double* polar, double* azimuth) {
  const Eigen::Vector3d u = plane.normal.normalized();
  *polar = std::acos(std::clamp(u.y(), -1.0, 1.0)) / kDegree;
  *azimuth = std::hypot(u.x(), u.z()) < 1e-12 ? plane.azimuth_deg : std::atan2(u.z(), u.x()) / kDegree;
}

Eigen::Vector3d* vector_field(PhysicalParameters& p, const std::string& base) {
  if (base == "gravity") return &p.gravity;
  if (base == "initial.linear_velocity") return &p.linear_velocity;
  if (base == "initial.angular_velocity") return &p.angular_velocity;
  return nullptr;
}

double* scalar_field(PhysicalParameters& p, const std::string& name) {
  if (name == "youngs_modulus") return &p.youngs_modulus;
  if (name == "poisson_ratio") return &p.poisson_ratio;
  if (name == "density") return &p.density;
  if (name == "mass_damping") return &p.mass_damping;
  if (name == "stiffness_damping") return &p.stiffness_damping;
  return nullptr;
}

// "gravity.y" -> (&p.gravity, 1)
Eigen::Vector3d* vector_component(PhysicalParameters& p, const std::string& name, int* axis) {
  const size_t dot = name.rfind('.');
  if (dot == std::string::npos) return nullptr;
  const std::string base = name.substr(0, dot), comp = name.substr(dot + 1);
  for (int a = 0; a < 3; ++a)
    if (comp == kAxes[a]) {
      *axis = a;
      return vector_field(p, base);
    }
  return nullptr;
}

}  // namespace

std::vector<std::string> all_parameter_names(const PhysicalParameters& p) {
  std::vector<std::string> names = {"youngs_modulus", "poisson_ratio", "density", "mass_damping", "stiffness_damping"};
  for (const char* base : {"gravity", "initial.linear_velocity", "initial.angular_velocity"})
    for (const char* a : kAxes) names.push_back(fmt::format("{}.{}", base, a));
  for (size_t k = 0; k < p.planes.size(); ++k)
    for (const char* f : {"height", "polar_deg", "azimuth_deg"}) names.push_back(plane_prefix(k) + f);
  return names;
}

namespace {

// The parameter name of a scene-key spelling, or the name itself.
std::string canonical_parameter_name(const std::string& name) {
  const std::string material = "material.";
  if (name.rfind(material, 0) == 0) {
    PhysicalParameters probe;
    if (scalar_field(probe, name.substr(material.size()))) return name.substr(material.size());
  }
  const std::string first_plane = "ground.planes[0].";
  if (name.rfind(first_plane, 0) == 0) return "ground." + name.substr(first_plane.size());
  return name;
}

}  // namespace

std::vector<std::string> expand_parameter_names(const std::vector<std::string>& names, const PhysicalParameters& p) {
  const std::vector<std::string> all = all_parameter_names(p);
  std::vector<std::string> out;
  for (const std::string& given : names) {
    const std::string n = canonical_parameter_name(given);
    PhysicalParameters copy = p;
    std::vector<std::string> expanded;
    if (vector_field(copy, n)) {
      for (const char* a : kAxes) expanded.push_back(n + "." + a);
    } else if (std::find(all.begin(), all.end(), n) == all.end()) {
      std::string list;
      for (const std::string& a : all) list += (list.empty() ? "" : ", ") + a;
      throw InputError(fmt::format("unknown parameter '{}'; the scene's parameters are: {} (and gravity, "
                                   "initial.linear_velocity, initial.angular_velocity for all three components)",
                                   given, list));
    } else {
      expanded.push_back(n);
    }
    for (const std::string& e : expanded) {
      if (std::find(out.begin(), out.end(), e) != out.end())
        throw InputError(fmt::format("parameter '{}' is named twice (as '{}'); name each parameter once", e, given));
      out.push_back(e);
    }
  }
  return out;
}

bool apply_parameter_override(nlohmann::json& config, const std::string& given, const nlohmann::json& value,
                              const std::string& file) {
  // A scene key (material.youngs_modulus, ground.height) is left to the scene parser.
  if (given.rfind("material.", 0) == 0 || given == "ground.height") return false;
  const std::string name = canonical_parameter_name(given);
  PhysicalParameters probe;
  int axis = 0;
  const bool scalar = scalar_field(probe, name) != nullptr;
  const bool component = vector_component(probe, name, &axis) != nullptr;
  const bool plane = name.rfind("ground.", 0) == 0 &&
                     (name.find("polar_deg") != std::string::npos || name.find("azimuth_deg") != std::string::npos ||
                      given.rfind("ground.planes[", 0) == 0);
  if (!scalar && !component && !plane) return false;
  if (!value.is_number())
    throw InputError(fmt::format("{}: --set {}: must be a number, found {}", file, given, value.dump()));
  const double x = value.get<double>();
  if (const std::string why = parameter_value_error(name, x); !why.empty())
    throw InputError(fmt::format("{}: --set {}={}: {}", file, given, value.dump(), why));
  if (scalar) {
    config["material"][name] = x;
    return true;
  }
  PhysicalParameters p = PhysicalParameters::from_scene(parse_scene(config, file));
  if (!plane) {
    set_parameter(p, name, x);
    const Eigen::Vector3d* v = vector_component(p, name, &axis);
    const std::string base = name.substr(0, name.rfind('.'));
    nlohmann::json& node = base == "gravity" ? config["gravity"] : config["initial"][base.substr(base.find('.') + 1)];
    node = {(*v)[0], (*v)[1], (*v)[2]};
    return true;
  }
  size_t k;
  std::string field;
  if (!parse_plane_name(name, p.planes.size(), &k, &field))
    throw InputError(fmt::format("--set {}: {}: the scene has {} ground plane(s) (ground.planes[0..{}]), and the plane "
                                 "parameters are height, polar_deg and azimuth_deg", given, file, p.planes.size(),
                                 int(p.planes.size()) - 1));
  set_parameter(p, name, x);
  nlohmann::json& node = config["ground"].contains("planes") ? config["ground"]["planes"][k] : config["ground"];
  if (field == "height") {
    node["height"] = x;
  } else {
    double polar, azimuth;
    plane_angles(p.planes[k], &polar, &azimuth);
    node.erase("normal");
    node["angles_deg"] = {polar, azimuth};
  }
  return true;
}

std::string parameter_set_argument(const PhysicalParameters& p, const std::string& name, double value) {
  // ground.height is the default of a planes list, not its first plane's: name the plane.
  const std::string key = name == "ground.height" ? "ground.planes[0].height" : name;
  return fmt::format("{}={:.17g}", key, value);
}

std::string parameter_value_error(const std::string& name, double value) {
  if (!std::isfinite(value)) return "must be a finite number";
  const std::string n = canonical_parameter_name(name);
  if ((n == "youngs_modulus" || n == "density") && !(value > 0)) return fmt::format("must be positive, found {:g}", value);
  if ((n == "mass_damping" || n == "stiffness_damping") && value < 0) return fmt::format("must not be negative, found {:g}", value);
  if (n == "poisson_ratio" && !(value > 0 && value < 0.5)) return fmt::format("must be in (0, 0.5), found {:g}", value);
  if (n.size() > 9 && n.compare(n.size() - 9, 9, "polar_deg") == 0 && !(value >= 0 && value <= 180))
    return fmt::format("must be in [0, 180] degrees, found {:g}", value);
  return "";
}

double get_parameter(const PhysicalParameters& p, const std::string& name) {
  PhysicalParameters& q = const_cast<PhysicalParameters&>(p);
  if (double* s = scalar_field(q, name)) return *s;
  int axis;
  if (Eigen::Vector3d* v = vector_component(q, name, &axis)) return (*v)[axis];
  size_t k;
  std::string field;
  if (parse_plane_name(name, p.planes.size(), &k, &field)) {
    if (field == "height") return p.planes[k].height;
    double polar, azimuth;
    plane_angles(p.planes[k], &polar, &azimuth);
    return field == "polar_deg" ? polar : azimuth;
  }
  throw InputError(fmt::format("unknown parameter '{}'", name));
}

void set_parameter(PhysicalParameters& p, const std::string& name, double value) {
  if (double* s = scalar_field(p, name)) {
    *s = value;
    return;
  }
  int axis;
  if (Eigen::Vector3d* v = vector_component(p, name, &axis)) {
    (*v)[axis] = value;
    return;
  }
  size_t k;
  std::string field;
  if (parse_plane_name(name, p.planes.size(), &k, &field)) {
    if (field == "height") {
      p.planes[k].height = value;
      return;
    }
    double polar, azimuth;
    plane_angles(p.planes[k], &polar, &azimuth);
    (field == "polar_deg" ? polar : azimuth) = value;
    p.planes[k].normal = normal_from_angles(polar, azimuth);
    p.planes[k].azimuth_deg = azimuth;
    return;
  }
  throw InputError(fmt::format("unknown parameter '{}'", name));
}

double parameter_gradient(const ParameterGradient& g, const PhysicalParameters& p, const std::string& name) {
  if (name == "youngs_modulus") return g.youngs_modulus;
  if (name == "poisson_ratio") return g.poisson_ratio;
  if (name == "density") return g.density;
  if (name == "mass_damping") return g.mass_damping;
  if (name == "stiffness_damping") return g.stiffness_damping;
  PhysicalParameters q = p;
  int axis;
  if (Eigen::Vector3d* v = vector_component(q, name, &axis)) {
    if (v == &q.gravity) return g.gravity[axis];
    if (v == &q.linear_velocity) return g.linear_velocity[axis];
    return g.angular_velocity[axis];
  }
  size_t k;
  std::string field;
  if (parse_plane_name(name, p.planes.size(), &k, &field)) {
    if (field == "height") return g.plane_height[k];
    double polar, azimuth;
    plane_angles(p.planes[k], &polar, &azimuth);
    const double sp = std::sin(polar * kDegree), cp = std::cos(polar * kDegree);
    const double sa = std::sin(azimuth * kDegree), ca = std::cos(azimuth * kDegree);
    const Eigen::Vector3d dn = field == "polar_deg" ? Eigen::Vector3d(cp * ca, -sp, cp * sa) : Eigen::Vector3d(-sp * sa, 0, sp * ca);
    return kDegree * g.plane_normal[k].dot(dn);
  }
  throw InputError(fmt::format("unknown parameter '{}'", name));
}

std::string parameter_unit(const std::string& name) {
  if (name == "youngs_modulus") return "Pa";
  if (name == "poisson_ratio") return "1";
  if (name == "density") return "kg/m^3";
  if (name == "mass_damping") return "1/s";
  if (name == "stiffness_damping") return "s";
  if (name.rfind("gravity", 0) == 0) return "m/s^2";
  if (name.rfind("initial.linear_velocity", 0) == 0) return "m/s";
  if (name.rfind("initial.angular_velocity", 0) == 0) return "rad/s";
  if (name.find("height") != std::string::npos) return "m";
  return "deg";
}

}  // namespace ssc
