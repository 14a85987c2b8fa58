// Named scalar parameters of a simulation, the vocabulary of `ssc gradient`, `sweep` and
// `reconstruct`: youngs_modulus, poisson_ratio, density, mass_damping,
// stiffness_damping, gravity.{x,y,z}, initial.linear_velocity.{x,y,z},
// initial.angular_velocity.{x,y,z}, and per ground plane k (prefix "ground." for the
// first plane, "ground.planes[k]." for the others) height, polar_deg and azimuth_deg
// (the normal is (sin p cos a, cos p, sin p sin a)). Vector names without a component
// ("gravity") expand to their three components.
#pragma once
#include <string>
#include <vector>

#include "models/sim/gradient.h"
#include "models/sim/simulation.h"

namespace ssc {

std::vector<std::string> all_parameter_names(const PhysicalParameters& p);
// Expands "gravity" to its components and checks every name; InputError listing the valid ones.
std::vector<std::string> expand_parameter_names(const std::vector<std::string>& names, const PhysicalParameters& p);

double get_parameter(const PhysicalParameters& p, const std::string& name);
void set_parameter(PhysicalParameters& p, const std::string& name, double value);
// d cost / d parameter from the adjoint's gradient (chain rule for the plane angles).
double parameter_gradient(const ParameterGradient& g, const PhysicalParameters& p, const std::string& name);
// SI unit of a parameter, for reports.
std::string parameter_unit(const std::string& name);

}  // namespace ssc
