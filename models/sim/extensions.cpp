// The extension table (see extensions.h).
#include "models/sim/extensions.h"

#include <fmt/format.h>

#include <cmath>
#include <limits>

#include "models/sim/parameter_table.h"
#include "runtime/errors.h"

namespace ssc {
namespace {

std::string plane_friction(size_t k) { return k == 0 ? "ground.friction" : fmt::format("ground.planes[{}].friction", k); }

bool starts_with(const std::string& s, const std::string& prefix) { return s.rfind(prefix, 0) == 0; }

// The modulus may change by at most this factor across the body in a plausible gradient, and
// by e^2 in a typical one.
constexpr double kPlausibleStiffnessRatio = 1000, kTypicalStiffnessLog = 2;

std::vector<ExtensionRow> make_table() {
  std::vector<ExtensionRow> rows;

  ExtensionRow friction;
  friction.name = "friction";
  friction.what = "Coulomb friction on every contact plane";
  friction.ops = {"friction"};
  friction.scene_keys = {"ground.friction", "ground.planes[k].friction", "ground.planes[k].friction_velocity"};
  friction.parameters = [](const Scene& s) {
    std::vector<std::string> names;
    for (size_t k = 0; k < s.planes.size(); ++k) names.push_back(plane_friction(k));
    return names;
  };
  friction.one_sided = true;
  friction.typical = [](double) { return 0.3; };
  friction.start_range = [](double) { return std::make_pair(0.02, 1.0); };
  friction.log_start = true;
  friction.owns = [](const std::string& p) { return p.find("friction") != std::string::npos; };
  friction.model_on = [](Scene& s) { s.friction_keys = true; };
  friction.switch_off = [](Scene& s) {
    s.friction_keys = false;
    for (PlaneSpec& p : s.planes) p.friction = 0;
  };
  rows.push_back(friction);

  ExtensionRow stiffness;
  stiffness.name = "heterogeneous_stiffness";
  stiffness.what = "a Young's modulus that changes smoothly across the body";
  stiffness.ops = {"stiffness_field"};
  stiffness.scene_keys = {"material.stiffness_gradient", "material.regions"};
  stiffness.overrides = {"material.stiffness_gradient=[0,0,0]"};
  stiffness.parameters = [](const Scene&) { return std::vector<std::string>{"material.stiffness_gradient"}; };
  stiffness.typical = [](double extent) { return kTypicalStiffnessLog / extent; };
  stiffness.start_range = [](double extent) { return std::make_pair(-1 / extent, 1 / extent); };
  stiffness.owns = [](const std::string& p) { return starts_with(p, "material.stiffness_gradient"); };
  stiffness.model_on = [](Scene& s) { s.material.stiffness_gradient_key = true; };
  stiffness.switch_off = [](Scene& s) {
    s.material.regions.clear();
    s.material.stiffness_gradient.setZero();
    s.material.stiffness_gradient_key = false;
  };
  rows.push_back(stiffness);

  ExtensionRow two_materials;
  two_materials.name = "two_materials";
  two_materials.what = "a body of two materials with a sharp plane interface";
  two_materials.ops = {"stiffness_field"};
  two_materials.scene_keys = {"material.regions"};
  two_materials.fit = ExtensionRow::Fit::ProposedRegion;
  two_materials.searched_degrees_of_freedom = 3;
  two_materials.parameters = [](const Scene&) {
    return std::vector<std::string>{"material.regions[0].youngs_modulus"};
  };
  two_materials.owns = [](const std::string& p) { return starts_with(p, "material.regions["); };
  two_materials.model_on = [](Scene&) {};
  two_materials.switch_off = [](Scene& s) { s.material.regions.clear(); };
  rows.push_back(two_materials);

  ExtensionRow plane;
  plane.name = "second_plane";
  plane.what = "a contact plane beyond the first: a wall, a table under a ramp";
  plane.ops = {"contact"};
  plane.scene_keys = {"ground.planes[1..]"};
  plane.fit = ExtensionRow::Fit::ProposedPlane;
  plane.parameters = [](const Scene& s) {
    return std::vector<std::string>{fmt::format("ground.planes[{}].height", s.planes.size())};
  };
  plane.event = "added_plane";
  plane.owns = [](const std::string& p) {
    return starts_with(p, "ground.planes[") && !starts_with(p, "ground.planes[0]") &&
           p.find(".height") != std::string::npos;
  };
  plane.model_on = [](Scene&) {};
  plane.switch_off = [](Scene& s) {
    if (s.planes.size() > 1) s.planes.resize(1);
  };
  rows.push_back(plane);

  ExtensionRow neo;
  neo.name = "nonlinear_material";
  neo.what = "a Neo-Hookean material in place of the corotated linear one";
  neo.ops = {"neo_hookean_system", "neo_hookean_correction"};
  neo.scene_keys = {"material.model"};
  neo.fit = ExtensionRow::Fit::ModelSwitch;
  neo.overrides = {"material.model=\"neo_hookean\""};
  neo.parameters = [](const Scene&) { return std::vector<std::string>{}; };
  neo.owns = [](const std::string&) { return false; };
  neo.model_on = [](Scene&) {};
  neo.switch_off = [](Scene& s) { s.material.neo_hookean = false; };
  rows.push_back(neo);

  ExtensionRow drag;
  drag.name = "air_drag";
  drag.what = "quadratic drag of the air (or whatever the body moves through) on its surface";
  drag.ops = {"air_drag"};
  drag.scene_keys = {"air_drag"};
  drag.overrides = {"air_drag=1"};
  drag.parameters = [](const Scene&) { return std::vector<std::string>{"air_drag"}; };
  drag.one_sided = true;
  drag.typical = [](double) { return 1.2; };
  drag.start_range = [](double) { return std::make_pair(0.3, 1.5); };
  drag.log_start = true;
  drag.event = "start";
  drag.owns = [](const std::string& p) { return p == "air_drag"; };
  drag.model_on = [](Scene& s) { s.air_drag_key = true; };
  drag.switch_off = [](Scene& s) {
    s.air_drag = 0;
    s.air_drag_key = false;
  };
  rows.push_back(drag);

  // The measurement: cameras.json may be wrong, not the physics.
  auto measurement = [&](const std::string& name, const std::string& what, const std::string& parameter,
                         const std::string& unit, double off, std::pair<double, double> range, const std::string& source,
                         std::function<std::string(double)> tell) {
    ExtensionRow m;
    m.name = name;
    m.what = what;
    m.fit = ExtensionRow::Fit::Measurement;
    m.parameters = [parameter](const Scene&) { return std::vector<std::string>{parameter}; };
    m.off_value = off;
    m.event = "start";
    m.owns = [parameter](const std::string& p) { return p == parameter; };
    m.model_on = [](Scene&) {};
    m.switch_off = [](Scene&) {};
    m.unit = unit;
    m.plausible = range;
    m.plausible_source = source;
    m.tell = std::move(tell);
    rows.push_back(m);
  };
  auto percent_off = [](double recorded_over_true, const std::string& what) {
    const double e = 100 * (recorded_over_true - 1);
    return fmt::format("{} look {:.1f} % too {}", what, std::abs(e), e > 0 ? "large" : "small");
  };
  measurement("focal_length", "the depth cameras' focal lengths (fx, fy in cameras.json) are off by a common factor",
              "camera.focal_scale", "1", 1, {0.8, 1.25},
              "calibrated or factory intrinsics are within a few %; 20 % is a calibration for another resolution or lens",
              [percent_off](double s) { return percent_off(1 / s, "the cameras' focal lengths (fx, fy in cameras.json)"); });
  measurement("depth_scale", "the recorded depths are off by a common factor (the depth unit, depth_scale in "
              "cameras.json)", "camera.depth_scale", "1", 1, {0.9, 1.1},
              "depth sensors' scale errors are about 1 %; 10 % is a wrong depth unit or an uncalibrated sensor",
              [percent_off](double k) { return percent_off(1 / k, "the recorded depths (depth_scale in cameras.json)"); });
  measurement("time_offset", "the frames' times are off by a constant (the recording's clock against the "
              "simulation's start)", "camera.time_offset", "s", 0, {-0.1, 0.1},
              "a recording's clock and the simulated start agree to within 0.1 s",
              [](double tau) {
                return fmt::format("the frames' times (cameras.json) look {:.4g} s {} than the motion they show", std::abs(tau),
                                   tau > 0 ? "earlier" : "later");
              });
  return rows;
}

}  // namespace

const std::vector<ExtensionRow>& extension_table() {
  static const std::vector<ExtensionRow> table = make_table();
  return table;
}

const ExtensionRow* find_extension(const std::string& name) {
  for (const ExtensionRow& row : extension_table())
    if (row.name == name) return &row;
  return nullptr;
}

std::vector<std::string> extension_names() {
  std::vector<std::string> names;
  for (const ExtensionRow& row : extension_table()) names.push_back(row.name);
  return names;
}

std::string extension_list() {
  std::string list;
  for (const ExtensionRow& row : extension_table()) list += (list.empty() ? "" : ", ") + row.name;
  return list;
}

std::string owner(const std::string& parameter) {
  for (const ExtensionRow& row : extension_table())
    if (row.owns(parameter)) return row.name;
  return parameter;
}

bool is_measurement_parameter(const std::string& parameter) {
  const ExtensionRow* row = find_extension(owner(parameter));
  return row && row->fit == ExtensionRow::Fit::Measurement;
}

std::string parameter_or_measurement_unit(const std::string& parameter) {
  if (is_measurement_parameter(parameter)) return find_extension(owner(parameter))->unit;
  return parameter_row(parameter).unit;
}

void model_fitted_extensions(Scene& scene, const std::vector<std::string>& fitted) {
  for (const std::string& name : fitted)
    for (const ExtensionRow& row : extension_table())
      if (row.owns(name)) row.model_on(scene);
}

void switch_off_extensions(Scene& scene) {
  for (const std::string& name : scene.extensions_off)
    if (const ExtensionRow* row = find_extension(name)) row->switch_off(scene);
}

std::pair<double, double> plausible_range(const Scene& scene, const std::string& parameter, double extent,
                                          std::string* source) {
  auto say = [&](const std::string& s) {
    if (source) *source = s;
  };
  if (const auto given = scene.plausible.find(parameter); given != scene.plausible.end()) {
    say(fmt::format("the scene's plausible.{}", parameter));
    return given->second;
  }
  if (const ExtensionRow* row = find_extension(owner(parameter)); row && row->fit == ExtensionRow::Fit::Measurement) {
    say(row->plausible_source);
    return row->plausible;
  }
  if (owner(parameter) == "heterogeneous_stiffness") {
    const double g = std::log(kPlausibleStiffnessRatio) / extent;
    say(fmt::format("the modulus changing at most {:g} times across the body's {:.3g} m", kPlausibleStiffnessRatio,
                    extent));
    return {-g, g};
  }
  const ParameterRow row = parameter_row(parameter);
  say(row.plausible_source);
  return {row.plausible_lower, row.plausible_upper};
}

std::string implausibility(const Scene& scene, const std::string& parameter, double value, double extent) {
  std::string source;
  const auto [lo, hi] = plausible_range(scene, parameter, extent, &source);
  if (value >= lo && value <= hi) return "";
  const std::string unit = parameter_or_measurement_unit(parameter);
  return fmt::format("{} = {:.4g}{} is outside its plausible range [{:g}, {:g}] ({}); no physical object of this kind "
                     "has it. If yours does, widen the range in the scene: \"plausible\": {{\"{}\": [LOWER, UPPER]}}",
                     parameter, value, unit == "1" ? "" : " " + unit, lo, hi, source, parameter);
}

}  // namespace ssc
