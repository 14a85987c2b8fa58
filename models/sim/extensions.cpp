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
  const std::string unit = parameter_row(parameter).unit;
  return fmt::format("{} = {:.4g}{} is outside its plausible range [{:g}, {:g}] ({}); no physical object of this kind "
                     "has it. If yours does, widen the range in the scene: \"plausible\": {{\"{}\": [LOWER, UPPER]}}",
                     parameter, value, unit == "1" ? "" : " " + unit, lo, hi, source, parameter);
}

}  // namespace ssc
