// Named scalar parameters of a simulation, the vocabulary of `ssc gradient`, `sweep` and
// `reconstruct`: youngs_modulus, poisson_ratio, density, mass_damping,
// stiffness_damping, gravity.{x,y,z}, initial.linear_velocity.{x,y,z},
// initial.angular_velocity.{x,y,z}, and per ground plane k (prefix "ground." for the
// first plane, "ground.planes[k]." for the others) height, polar_deg and azimuth_deg
// (the normal is (sin p cos a, cos p, sin p sin a)). Vector names without a component
// ("gravity") expand to their three components.
#pragma once
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "models/sim/gradient.h"
#include "models/sim/simulation.h"

namespace ssc {

std::vector<std::string> all_parameter_names(const PhysicalParameters& p);
// Expands "gravity" to its components, maps the scene-key spelling of a material parameter
// ("material.youngs_modulus") and of the first plane ("ground.planes[0].height") to the
// parameter name, and checks every name; InputError listing the valid ones, or naming a
// parameter given twice.
std::vector<std::string> expand_parameter_names(const std::vector<std::string>& names, const PhysicalParameters& p);

// `--set NAME=VALUE` with a parameter name that is not itself a scene key (youngs_modulus,
// gravity.y, initial.linear_velocity.x, ground.polar_deg, ground.planes[k].height, ...):
// writes the value into the scene config under its scene key (material.youngs_modulus,
// gravity[1], ground.angles_deg, ...). False if NAME is no such parameter name.
bool apply_parameter_override(nlohmann::json& config, const std::string& name, const nlohmann::json& value,
                              const std::string& file);
// A `--set` argument that gives the parameter this value: what result.json lists under
// "set", so that a fit can be fed back into any command.
std::string parameter_set_argument(const PhysicalParameters& p, const std::string& name, double value);
// Empty if the parameter may take this value, else why not (E > 0, 0 < nu < 0.5, ...).
std::string parameter_value_error(const std::string& name, double value);

double get_parameter(const PhysicalParameters& p, const std::string& name);
void set_parameter(PhysicalParameters& p, const std::string& name, double value);
// d cost / d parameter from the adjoint's gradient (chain rule for the plane angles).
double parameter_gradient(const ParameterGradient& g, const PhysicalParameters& p, const std::string& name);
// SI unit of a parameter, for reports.
std::string parameter_unit(const std::string& name);

}  // namespace ssc
