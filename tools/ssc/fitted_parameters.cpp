// Reads a reconstruct result.json's fitted parameters (see fitted_parameters.h).
#include "tools/ssc/fitted_parameters.h"

#include <fmt/format.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "models/sim/scene.h"
#include "runtime/errors.h"

namespace ssc {

FittedParameters read_fitted_parameters(const std::string& path) {
  FittedParameters f;
  if (path.empty()) return f;
  std::ifstream in(path);
  if (!in) throw InputError(fmt::format("{}: cannot read the file (--params names a result.json of ssc reconstruct)", path));
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(in);
  } catch (const std::exception& e) {
    throw InputError(fmt::format("{}: not valid JSON ({})", path, e.what()));
  }
  if (!j.is_object() || !j.contains("set") || !j["set"].is_array() || !j.contains("parameters") ||
      !j["parameters"].is_object())
    throw InputError(fmt::format("{}: expected a result.json of ssc reconstruct, with \"set\" (an array of "
                                 "\"name=value\") and \"parameters\" (an object)",
                                 path));
  for (const auto& s : j["set"]) {
    if (!s.is_string()) throw InputError(fmt::format("{}: \"set\" must hold strings \"name=value\"", path));
    f.set.push_back(s.get<std::string>());
  }
  for (const auto& [name, value] : j["parameters"].items()) f.names.push_back(name);
  const std::filesystem::path manifest = std::filesystem::path(path).parent_path() / "ssc.json";
  std::ifstream m(manifest);
  if (!m) return f;
  try {
    const nlohmann::json mj = nlohmann::json::parse(m);
    f.manifest = manifest.string();
    f.scene_file = mj.at("scene").value("file", "");
    f.scene_resolved = mj.at("scene").at("resolved");
    f.observations_hash = mj.contains("observations") ? mj["observations"].value("fnv1a64", "") : "";
  } catch (const std::exception&) {
    f.manifest.clear();  // not a manifest of a fit: nothing to check against
  }
  return f;
}

std::string check_fitted_on(const FittedParameters& f, const std::string& params_path, const Scene& scene,
                            const std::string& scene_path, const std::string& observations_hash) {
  if (f.manifest.empty() || !f.scene_resolved.is_object()) return "";
  for (const char* key : {"object", "grid"}) {
    const nlohmann::json fitted = f.scene_resolved.value(key, nlohmann::json()), here = scene.resolved.value(key, nlohmann::json());
    if (fitted != here)
      throw InputError(fmt::format(
          "--params {}: the fit ran on {} (its {}), whose \"{}\" differs from {}'s: these parameters belong to "
          "another body. Fit {} first (ssc reconstruct), or give the scene the fit ran on",
          params_path, f.scene_file, f.manifest, key, scene_path, scene_path));
  }
  if (!f.observations_hash.empty() && !observations_hash.empty() && f.observations_hash != observations_hash)
    return fmt::format("--params {}: the fit ran on other observations than these (its {} records folder hash {}, "
                       "these have {}): the residuals show how the fitted parameters predict new data",
                       params_path, f.manifest, f.observations_hash, observations_hash);
  return "";
}

}  // namespace ssc
