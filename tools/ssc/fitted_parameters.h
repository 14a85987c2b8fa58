// The fitted parameters of a reconstruct result.json, as the --set arguments that give them
// and the parameter names (which the scene must model: a friction coefficient turns friction
// on). An empty path gives none.
#pragma once
#include <string>
#include <vector>

namespace ssc {

struct FittedParameters {
  std::vector<std::string> set, names;
};

FittedParameters read_fitted_parameters(const std::string& path);

}  // namespace ssc
