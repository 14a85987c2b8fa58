// Physical units for scenes written in other scales (the paper's section "Physical
// Units"). A scene in scene units (length L', mass M', time T') maps to SI with the
// factors f_length = metres per scene length, f_mass = kg per scene mass, f_time = s per
// scene time. Derived quantities convert by their dimensions:
//   Young's modulus (Pa = kg m^-1 s^-2):  E = E' f_mass / (f_length f_time^2)
//   density (kg m^-3):                    rho = rho' f_mass / f_length^3
//   gravity, accelerations (m s^-2):      g = g' f_length / f_time^2
//   velocities (m s^-1): f_length/f_time; angular velocity (s^-1): 1/f_time;
//   mass damping (s^-1): 1/f_time; stiffness damping (s): f_time; heights (m): f_length.
// The paper converts E with f_mass f_length / f_time^2 (treating E as a force), which is
// right only when f_length = 1; ssc uses the dimensionally correct factor above.
// The scene's "units" section gives either the factors directly
//   {"length": f_length, "mass": f_mass, "time": f_time}
// or the real object's measurements, from which they follow:
//   {"object_size": S_metres, "object_mass": M_kg, "time": f_time}
//   f_length = S / (longest side of the object in scene units), f_mass = M / (rho' V').
#pragma once
#include <string>

#include "models/grid/sim_grid.h"
#include "models/sim/scene.h"

namespace ssc {

struct UnitScales {
  double length = 1, mass = 1, time = 1;
  bool identity() const { return length == 1 && mass == 1 && time == 1; }
};

// From scene.extra["units"] (identity without one); the grid gives the object's extent and volume.
UnitScales unit_scales(const Scene& scene, const SimGrid& grid);

// Converts a named parameter (models/sim/parameters.h names) from scene units to SI.
double to_si(const std::string& name, double value, const UnitScales& u);

}  // namespace ssc
