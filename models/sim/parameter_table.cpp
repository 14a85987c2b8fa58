// The parameter table (see parameter_table.h).
#include "models/sim/parameter_table.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "runtime/errors.h"
#include "models/sim/scene.h"

namespace ssc {
namespace {

constexpr double kDegree = 3.14159265358979323846 / 180.0;
constexpr double kInf = std::numeric_limits<double>::infinity();

// Plausible ranges (docs/decisions.md, "Plausible ranges").
void set_plausible(ParameterRow& r, double lower, double upper, const char* source) {
  r.plausible_lower = lower, r.plausible_upper = upper;
  r.plausible_source = source;
}
const char* const kModulusSource = "solids from the softest gels (10 Pa) to diamond (1.2e12 Pa)";
const char* const kAxes[3] = {"x", "y", "z"};

std::string plane_prefix(size_t k) { return k == 0 ? "ground." : fmt::format("ground.planes[{}].", k); }

void plane_angles(const PlaneSpec& plane, double* polar, double* azimuth) {
  const Eigen::Vector3d u = plane.normal.normalized();
  *polar = std::acos(std::clamp(u.y(), -1.0, 1.0)) / kDegree;
  *azimuth = std::hypot(u.x(), u.z()) < 1e-12 ? plane.azimuth_deg : std::atan2(u.z(), u.x()) / kDegree;
}

void set_plane_angles(PlaneSpec& plane, double polar, double azimuth) {
  plane.normal = normal_from_angles(polar, azimuth);
  plane.azimuth_deg = azimuth;
}

ParameterRow material_row(const std::string& name, const std::string& unit, int mass, int length, int time,
                          double PhysicalParameters::*field, double ParameterGradient::*grad) {
  ParameterRow r;
  r.name = name;
  r.unit = unit;
  r.mass = mass, r.length = length, r.time = time;
  r.transform = ParameterRow::Transform::Positive;
  r.lower = 0;
  r.scene_key = "material." + name;
  r.graph_input = name;
  r.get = [field](const PhysicalParameters& p) { return p.*field; };
  r.set = [field](PhysicalParameters& p, double v) { p.*field = v; };
  r.gradient = [grad](const ParameterGradient& g, const PhysicalParameters&) { return g.*grad; };
  return r;
}

void add_vector_rows(std::vector<ParameterRow>& rows, const std::string& base, const std::string& unit, int length,
                     int time, Eigen::Vector3d PhysicalParameters::*field, Eigen::Vector3d ParameterGradient::*grad,
                     const std::string& graph_input) {
  for (int a = 0; a < 3; ++a) {
    ParameterRow r;
    r.name = base + "." + kAxes[a];
    r.unit = unit;
    r.length = length, r.time = time;
    r.scene_key = fmt::format("{}[{}]", base, a);
    r.graph_input = graph_input;
    r.get = [field, a](const PhysicalParameters& p) { return (p.*field)[a]; };
    r.set = [field, a](PhysicalParameters& p, double v) { (p.*field)[a] = v; };
    r.gradient = [grad, a](const ParameterGradient& g, const PhysicalParameters&) { return (g.*grad)[a]; };
    rows.push_back(r);
  }
}

// d cost / d angle from the gradient with respect to the unit normal (chain rule).
double angle_gradient(const ParameterGradient& g, const PhysicalParameters& p, size_t k, bool polar_angle) {
  double polar, azimuth;
  plane_angles(p.planes[k], &polar, &azimuth);
  const double sp = std::sin(polar * kDegree), cp = std::cos(polar * kDegree);
  const double sa = std::sin(azimuth * kDegree), ca = std::cos(azimuth * kDegree);
  const Eigen::Vector3d dn = polar_angle ? Eigen::Vector3d(cp * ca, -sp, cp * sa) : Eigen::Vector3d(-sp * sa, 0, sp * ca);
  return kDegree * g.plane_normal[k].dot(dn);
}

void add_plane_rows(std::vector<ParameterRow>& rows, size_t k) {
  const std::string prefix = plane_prefix(k);
  const std::string key = fmt::format("ground.planes[{}].", k);
  ParameterRow height;
  height.name = prefix + "height";
  height.unit = "m";
  height.length = 1;
  height.scene_key = key + "height";
  height.graph_input = "ground_planes";
  height.get = [k](const PhysicalParameters& p) { return p.planes[k].height; };
  height.set = [k](PhysicalParameters& p, double v) { p.planes[k].height = v; };
  height.gradient = [k](const ParameterGradient& g, const PhysicalParameters&) { return g.plane_height[k]; };
  rows.push_back(height);
  for (const bool is_polar : {true, false}) {
    ParameterRow r;
    r.name = prefix + (is_polar ? "polar_deg" : "azimuth_deg");
    r.unit = "deg";
    r.transform = ParameterRow::Transform::Bounded;
    r.optimiser_lower = is_polar ? 0 : -180;
    r.optimiser_upper = is_polar ? 90 : 180;
    if (is_polar) r.lower = 0, r.upper = 180, r.lower_inclusive = r.upper_inclusive = true;
    r.scene_key = key + "angles_deg";
    r.graph_input = "ground_planes";
    r.get = [k, is_polar](const PhysicalParameters& p) {
      double polar, azimuth;
      plane_angles(p.planes[k], &polar, &azimuth);
      return is_polar ? polar : azimuth;
    };
    r.set = [k, is_polar](PhysicalParameters& p, double v) {
      double polar, azimuth;
      plane_angles(p.planes[k], &polar, &azimuth);
      (is_polar ? polar : azimuth) = v;
      set_plane_angles(p.planes[k], polar, azimuth);
    };
    r.gradient = [k, is_polar](const ParameterGradient& g, const PhysicalParameters& p) {
      return angle_gradient(g, p, k, is_polar);
    };
    rows.push_back(r);
  }
  for (const bool velocity : {false, true}) {  // ops/friction.h: mu and the smoothing velocity
    ParameterRow r;
    r.name = prefix + (velocity ? "friction_velocity" : "friction");
    r.unit = velocity ? "m/s" : "1";
    if (velocity) r.length = 1, r.time = -1;
    r.transform = velocity ? ParameterRow::Transform::Positive : ParameterRow::Transform::Bounded;
    if (!velocity) {
      r.optimiser_lower = 0, r.optimiser_upper = 2;
      set_plausible(r, 0, 1.5, "dry contact: 0.04 (PTFE) to about 1.5 (rubber)");
    }
    r.lower = 0, r.lower_inclusive = !velocity;
    r.scene_key = key + (velocity ? "friction_velocity" : "friction");
    r.graph_input = "friction";
    r.graph_component = 2 * int(k) + (velocity ? 1 : 0);
    r.get = [k, velocity](const PhysicalParameters& p) { return velocity ? p.planes[k].friction_velocity : p.planes[k].friction; };
    r.set = [k, velocity](PhysicalParameters& p, double v) { (velocity ? p.planes[k].friction_velocity : p.planes[k].friction) = v; };
    r.gradient = [c = r.graph_component](const ParameterGradient& g, const PhysicalParameters&) {
      return g.input_entry("friction", c);
    };
    rows.push_back(r);
  }
}

// The heterogeneous_stiffness extension (ops/stiffness_field.h): each region's modulus and the
// stiffness gradient's components, written into their graph inputs as they are.
void add_stiffness_field_rows(std::vector<ParameterRow>& rows, size_t region_count) {
  for (size_t k = 0; k < region_count; ++k) {
    ParameterRow r;
    r.name = fmt::format("material.regions[{}].youngs_modulus", k);
    r.unit = "Pa";
    r.mass = 1, r.length = -1, r.time = -2;
    r.transform = ParameterRow::Transform::Positive;
    r.lower = 0;
    r.scene_key = r.name;
    r.graph_input = "region_youngs";
    set_plausible(r, 10, 1.2e12, kModulusSource);
    r.graph_component = int(k);
    r.get = [k](const PhysicalParameters& p) { return p.region_youngs[k]; };
    r.set = [k](PhysicalParameters& p, double v) { p.region_youngs[k] = v; };
    r.gradient = [k](const ParameterGradient& g, const PhysicalParameters&) { return g.input_entry("region_youngs", int(k)); };
    rows.push_back(r);
  }
  for (int a = 0; a < 3; ++a) {
    ParameterRow r;
    r.name = fmt::format("material.stiffness_gradient.{}", kAxes[a]);
    r.unit = "1/m";
    r.length = -1;
    r.scene_key = fmt::format("material.stiffness_gradient[{}]", a);
    r.graph_input = "stiffness_gradient";
    r.graph_component = a;
    r.get = [a](const PhysicalParameters& p) { return p.stiffness_gradient[a]; };
    r.set = [a](PhysicalParameters& p, double v) { p.stiffness_gradient[a] = v; };
    r.gradient = [a](const ParameterGradient& g, const PhysicalParameters&) { return g.input_entry("stiffness_gradient", a); };
    rows.push_back(r);
  }
}

}  // namespace

std::string ParameterRow::value_error(double value) const {
  if (!std::isfinite(value)) return fmt::format("must be a finite number, found {}", value);
  const bool above = lower_inclusive ? value >= lower : value > lower;
  const bool below = upper_inclusive ? value <= upper : value < upper;
  if (above && below) return "";
  if (upper == kInf) return fmt::format("must be {}, found {:g}", lower == 0 ? (lower_inclusive ? "non-negative" : "positive")
                                                                              : fmt::format("above {:g}", lower), value);
  return fmt::format("must be in {}{:g}, {:g}{}, found {:g}", lower_inclusive ? "[" : "(", lower, upper,
                     upper_inclusive ? "]" : ")", value);
}

std::vector<ParameterRow> parameter_table(const PhysicalParameters& p) {
  using PP = PhysicalParameters;
  using PG = ParameterGradient;
  std::vector<ParameterRow> rows = {
      material_row("youngs_modulus", "Pa", 1, -1, -2, &PP::youngs_modulus, &PG::youngs_modulus),
      material_row("poisson_ratio", "1", 0, 0, 0, &PP::poisson_ratio, &PG::poisson_ratio),
      material_row("density", "kg/m^3", 1, -3, 0, &PP::density, &PG::density),
      material_row("mass_damping", "1/s", 0, 0, -1, &PP::mass_damping, &PG::mass_damping),
      material_row("stiffness_damping", "s", 0, 0, 1, &PP::stiffness_damping, &PG::stiffness_damping),
  };
  set_plausible(rows[0], 10, 1.2e12, kModulusSource);
  set_plausible(rows[2], 1, 22600, "aerogels (1 kg/m^3) to osmium (22600 kg/m^3)");
  ParameterRow& nu = rows[1];
  nu.transform = ParameterRow::Transform::Bounded;
  nu.optimiser_lower = 0.01, nu.optimiser_upper = 0.49;
  nu.upper = 0.5;
  nu.lower_inclusive = true;  // nu = 0 (no lateral contraction) is valid, as in the scene
  for (ParameterRow* damping : {&rows[3], &rows[4]}) damping->lower_inclusive = true;
  add_vector_rows(rows, "gravity", "m/s^2", 1, -2, &PP::gravity, &PG::gravity, "gravity");
  add_vector_rows(rows, "initial.linear_velocity", "m/s", 1, -1, &PP::linear_velocity, &PG::linear_velocity, "v_prev");
  add_vector_rows(rows, "initial.angular_velocity", "rad/s", 0, -1, &PP::angular_velocity, &PG::angular_velocity, "v_prev");
  for (size_t k = 0; k < p.planes.size(); ++k) add_plane_rows(rows, k);
  add_stiffness_field_rows(rows, p.region_youngs.size());
  ParameterRow drag;  // ops/air_drag.h
  drag.name = drag.scene_key = drag.graph_input = "air_drag";
  drag.unit = "kg/m^3";
  drag.mass = 1, drag.length = -3;
  drag.transform = ParameterRow::Transform::Positive;
  drag.lower = 0, drag.lower_inclusive = true;
  drag.graph_component = 0;
  set_plausible(drag, 0, 1.5, "air: 1.2 kg/m^3; 0 to 1.5 covers the drag of common shapes in air");
  drag.get = [](const PhysicalParameters& p) { return p.air_drag; };
  drag.set = [](PhysicalParameters& p, double v) { p.air_drag = v; };
  drag.gradient = [](const ParameterGradient& g, const PhysicalParameters&) { return g.input_entry("air_drag", 0); };
  rows.push_back(drag);
  return rows;
}

const ParameterRow* find_parameter_row(const std::vector<ParameterRow>& table, const std::string& name) {
  for (const ParameterRow& r : table)
    if (r.name == name) return &r;
  return nullptr;
}

ParameterRow parameter_row(const std::string& name) {
  PhysicalParameters shape;
  shape.planes.resize(1);
  // The index in "ground.planes[k]." or "material.regions[k].", or -1.
  const auto index_after = [&](const std::string& prefix) {
    return name.rfind(prefix, 0) == 0 ? std::atoi(name.c_str() + prefix.size()) : -1;
  };
  if (const int k = index_after("ground.planes["); k >= 0 && k < 64) shape.planes.resize(size_t(k) + 1);
  if (const int k = index_after("material.regions["); k >= 0 && k < 64) shape.region_youngs.resize(size_t(k) + 1);
  const std::vector<ParameterRow> table = parameter_table(shape);
  if (const ParameterRow* r = find_parameter_row(table, name)) return *r;
  throw InputError(fmt::format("unknown parameter '{}'", name));
}

}  // namespace ssc
