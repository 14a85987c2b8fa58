// The one table of physical parameters: per parameter its name (the vocabulary of --set,
// --fit, --param and result.json), SI unit and dimension, the optimiser's transform, the
// range of valid values, the scene key it is read from, the graph input it feeds, and how it
// is read from and written into PhysicalParameters and read from the adjoint's gradient.
// Everything that names a parameter (models/sim/parameters.h, models/sim/units.h,
// models/optim/parameter_space.h) looks it up here; a new parameter is one row.
#pragma once
#include <functional>
#include <limits>
#include <string>
#include <vector>

#include "models/sim/gradient.h"
#include "models/sim/simulation.h"

namespace ssc {

struct ParameterRow {
  std::string name;       // "youngs_modulus", "gravity.y", "ground.planes[1].height"
  std::string unit;       // SI: "Pa", "m/s^2", "deg", ...
  int mass = 0, length = 0, time = 0;  // the unit is kg^mass m^length s^time (for scene units)
  // How an optimiser moves it (models/optim/parameter_space.h): exp(z), a sigmoid onto
  // [optimiser_lower, optimiser_upper], or a scaled free coordinate.
  enum class Transform { Positive, Bounded, Free } transform = Transform::Free;
  double optimiser_lower = 0, optimiser_upper = 0;
  // Valid values: lower < x < upper (or <= where inclusive).
  double lower = -std::numeric_limits<double>::infinity(), upper = std::numeric_limits<double>::infinity();
  bool lower_inclusive = false, upper_inclusive = false;
  // Values a physical object can have (docs/decisions.md, "Plausible ranges"): a fit is
  // bounded by them and a diagnosis names no cause outside them. Unlimited by default.
  double plausible_lower = -std::numeric_limits<double>::infinity();
  double plausible_upper = std::numeric_limits<double>::infinity();
  std::string plausible_source;  // what the range stands for, for messages
  std::string scene_key;    // where the scene sets it, e.g. "material.youngs_modulus", "gravity[1]"
  std::string graph_input;  // the timestep graph's input tensor it feeds (models/sim/timestep_graph.h)
  // The entry of graph_input (per batch item) that holds the value as it is: the simulation
  // writes it there and the gradient reads its cotangent there (ParameterGradient::input).
  // -1: the simulation packs the input itself (a plane's normal from its two angles).
  int graph_component = -1;
  std::function<double(const PhysicalParameters&)> get;
  std::function<void(PhysicalParameters&, double)> set;
  std::function<double(const ParameterGradient&, const PhysicalParameters&)> gradient;

  // Empty if the value is valid, else why not ("must be positive, found 0").
  std::string value_error(double value) const;
};

// Every parameter of a scene with these parameters (the plane rows depend on the number of
// ground planes), in the order `ssc gradient` lists them.
std::vector<ParameterRow> parameter_table(const PhysicalParameters& p);
// The row of a name; nullptr if there is none.
const ParameterRow* find_parameter_row(const std::vector<ParameterRow>& table, const std::string& name);
// The row of a name for any scene shape (plane index beyond the scene's planes allowed);
// InputError for an unknown name.
ParameterRow parameter_row(const std::string& name);

}  // namespace ssc
