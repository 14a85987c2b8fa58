// Named parameters (see parameters.h), looked up in the parameter table (parameter_table.h).
#include "models/sim/parameters.h"

#include <fmt/format.h>

#include <algorithm>

#include "runtime/errors.h"
#include "models/sim/parameter_table.h"
#include "models/sim/scene.h"

namespace ssc {
namespace {

// The parameter name of a scene-key spelling ("material.youngs_modulus",
// "ground.planes[0].height"), or the name itself.
bool is_stiffness_field_name(const std::string& name) {
  return name.rfind("material.regions[", 0) == 0 || name.rfind("material.stiffness_gradient", 0) == 0;
}

std::string canonical_parameter_name(const std::string& name) {
  const std::string material = "material.";
  if (name.rfind(material, 0) == 0 && !is_stiffness_field_name(name) &&
      parameter_row(name.substr(material.size())).scene_key == name)
    return name.substr(material.size());
  const std::string first_plane = "ground.planes[0].";
  if (name.rfind(first_plane, 0) == 0) return "ground." + name.substr(first_plane.size());
  return name;
}

bool is_vector_base(const std::vector<ParameterRow>& table, const std::string& name) {
  return !find_parameter_row(table, name) && find_parameter_row(table, name + ".x") && find_parameter_row(table, name + ".z");
}

const ParameterRow& row_of(const std::vector<ParameterRow>& table, const std::string& name) {
  if (const ParameterRow* r = find_parameter_row(table, name)) return *r;
  throw InputError(fmt::format("unknown parameter '{}'", name));
}

}  // namespace

std::vector<std::string> all_parameter_names(const PhysicalParameters& p) {
  std::vector<std::string> names;
  for (const ParameterRow& r : parameter_table(p)) names.push_back(r.name);
  return names;
}

std::vector<std::string> expand_parameter_names(const std::vector<std::string>& names, const PhysicalParameters& p) {
  const std::vector<ParameterRow> table = parameter_table(p);
  std::vector<std::string> out;
  for (const std::string& given : names) {
    const std::string n = canonical_parameter_name(given);
    std::vector<std::string> expanded;
    if (is_vector_base(table, n)) {
      for (const char* a : {"x", "y", "z"}) expanded.push_back(n + "." + a);
    } else if (find_parameter_row(table, n)) {
      expanded.push_back(n);
    } else {
      std::string list;
      for (const ParameterRow& r : table) list += (list.empty() ? "" : ", ") + r.name;
      throw InputError(fmt::format("unknown parameter '{}'; the scene's parameters are: {} (and gravity, "
                                   "initial.linear_velocity, initial.angular_velocity for all three components)",
                                   given, list));
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
  // A scene key (material.youngs_modulus, ground.height, ground.friction) is left to the scene parser.
  if ((given.rfind("material.", 0) == 0 && !is_stiffness_field_name(given)) || given == "ground.height" ||
      given == "ground.friction" || given == "ground.friction_velocity")
    return false;
  const std::string name = canonical_parameter_name(given);
  const bool plane_name = name.rfind("ground.", 0) == 0;
  ParameterRow row;
  try {
    row = parameter_row(name);
  } catch (const InputError&) {
    // Scene keys that are not parameters (ground.stiffness) are left to the scene parser; a
    // plane of a list ("ground.planes[1].x") has no other spelling.
    if (!plane_name || name.find("planes[") == std::string::npos) return false;
    throw InputError(fmt::format("{}: --set {}: the plane parameters are ground.planes[k].height, .polar_deg, "
                                 ".azimuth_deg, .friction and .friction_velocity", file, given));
  }
  if (!value.is_number()) throw InputError(fmt::format("{}: --set {}: must be a number, found {}", file, given, value.dump()));
  const double x = value.get<double>();
  if (const std::string why = row.value_error(x); !why.empty())
    throw InputError(fmt::format("{}: --set {}={}: {}", file, given, value.dump(), why));
  if (row.scene_key.rfind("material.", 0) == 0 && !is_stiffness_field_name(name)) {
    config["material"][name] = x;
    return true;
  }
  PhysicalParameters p = PhysicalParameters::from_scene(parse_scene(config, file));
  const std::vector<ParameterRow> table = parameter_table(p);
  const ParameterRow* scene_row = find_parameter_row(table, name);
  if (!scene_row && is_stiffness_field_name(name))
    throw InputError(fmt::format("{}: --set {}: the scene has {} material region(s) (material.regions[0..{}])", file,
                                 given, p.region_youngs.size(), int(p.region_youngs.size()) - 1));
  if (!scene_row)
    throw InputError(fmt::format("{}: --set {}: the scene has {} ground plane(s) (ground.planes[0..{}])", file, given,
                                 p.planes.size(), int(p.planes.size()) - 1));
  scene_row->set(p, x);
  const std::string& key = scene_row->scene_key;
  if (name.rfind("material.regions[", 0) == 0) {
    config["material"]["regions"][size_t(std::atoi(key.c_str() + key.find('[') + 1))]["youngs_modulus"] = x;
    return true;
  }
  if (key.find('[') == std::string::npos && key.find('.') == std::string::npos) {  // a top-level number (air_drag)
    config[key] = x;
    return true;
  }
  if (name.rfind("material.stiffness_gradient", 0) == 0) {
    config["material"]["stiffness_gradient"] = {p.stiffness_gradient[0], p.stiffness_gradient[1], p.stiffness_gradient[2]};
    return true;
  }
  if (!plane_name) {  // a vector component, "gravity[1]": the whole vector is written
    const std::string base = key.substr(0, key.find('['));
    Eigen::Vector3d v;
    for (int a = 0; a < 3; ++a) v[a] = row_of(table, fmt::format("{}.{}", base, "xyz"[a])).get(p);
    nlohmann::json& node = base == "gravity" ? config["gravity"] : config["initial"][base.substr(base.find('.') + 1)];
    node = {v[0], v[1], v[2]};
    return true;
  }
  const size_t k = size_t(std::atoi(key.c_str() + key.find('[') + 1));
  nlohmann::json& node = config["ground"].contains("planes") ? config["ground"]["planes"][k] : config["ground"];
  const auto ends_with = [&](const char* tail) {
    const std::string t(tail);
    return key.size() > t.size() && key.compare(key.size() - t.size(), t.size(), t) == 0;
  };
  if (ends_with("height")) {
    node["height"] = x;
  } else if (ends_with("friction")) {
    node["friction"] = x;
  } else if (ends_with("friction_velocity")) {
    node["friction_velocity"] = x;
  } else {
    const std::string prefix = name.substr(0, name.rfind('.') + 1);
    node.erase("normal");
    node["angles_deg"] = {row_of(table, prefix + "polar_deg").get(p), row_of(table, prefix + "azimuth_deg").get(p)};
  }
  return true;
}

std::string parameter_set_argument(const PhysicalParameters& p, const std::string& name, double value) {
  // ground.height (.friction) is the default of a planes list, not its first plane's: name the plane.
  const std::string key = name == "ground.height"     ? "ground.planes[0].height"
                          : name == "ground.friction" ? "ground.planes[0].friction"
                          : name == "ground.friction_velocity" ? "ground.planes[0].friction_velocity"
                                                      : name;
  return fmt::format("{}={:.17g}", key, value);
}

std::string parameter_value_error(const std::string& name, double value) {
  try {
    return parameter_row(canonical_parameter_name(name)).value_error(value);
  } catch (const InputError&) {
    return std::isfinite(value) ? "" : "must be a finite number";
  }
}

double get_parameter(const PhysicalParameters& p, const std::string& name) {
  return row_of(parameter_table(p), name).get(p);
}

void set_parameter(PhysicalParameters& p, const std::string& name, double value) {
  row_of(parameter_table(p), name).set(p, value);
}

double parameter_gradient(const ParameterGradient& g, const PhysicalParameters& p, const std::string& name) {
  return row_of(parameter_table(p), name).gradient(g, p);
}

std::string parameter_unit(const std::string& name) { return parameter_row(name).unit; }

}  // namespace ssc
