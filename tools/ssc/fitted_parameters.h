// The fitted parameters of a reconstruct result.json, as the --set arguments that give them
// and the parameter names (which the scene must model: a friction coefficient turns friction
// on), and what the fit ran on, from the ssc.json beside it (where there is one). An empty
// path gives none.
#pragma once
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

namespace ssc {

struct Scene;

struct FittedParameters {
  std::vector<std::string> set, names;
  std::string manifest;               // the ssc.json beside result.json, or empty
  std::string scene_file;             // the scene the fit ran on, as its manifest names it
  nlohmann::json scene_resolved;      // that scene, resolved (null without a manifest)
  std::string observations_hash;      // the fingerprint of the fit's observation folder
};

FittedParameters read_fitted_parameters(const std::string& path);

// Throws an InputError if the fit ran on a body other than `scene`'s (its object or grid
// differ: the parameters belong to another scene); "" if they match or the fit's manifest is
// missing, else a warning when the observations differ from `observations_hash`.
std::string check_fitted_on(const FittedParameters& f, const std::string& params_path, const Scene& scene,
                            const std::string& scene_path, const std::string& observations_hash);

}  // namespace ssc
