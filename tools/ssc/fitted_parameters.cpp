// Reads a reconstruct result.json's fitted parameters (see fitted_parameters.h).
#include "tools/ssc/fitted_parameters.h"

#include <fmt/format.h>

#include <fstream>
#include <nlohmann/json.hpp>

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
  return f;
}

}  // namespace ssc
