// The diagnosis's models, built from the extension table (models/sim/extensions.h): each
// candidate's spec, the placebos that stand for no missing effect, and the proposals the data
// make for the candidates that need one (a plane where the fitted body goes while the
// observations show it does not; a material interface across the fitted stiffness gradient).
#pragma once
#include <string>
#include <vector>

#include "models/diagnosis/model_fit.h"
#include "models/sim/extensions.h"

namespace ssc {

// "ground.friction" for plane 0, "ground.planes[k].friction" for the others.
std::string plane_parameter(int k, const std::string& key);
// Parameters (after expansion: material.stiffness_gradient is 3) a candidate fits in this scene.
int extra_parameter_count(const ExtensionRow& row, const Scene& scene);

// The spec of an OffValue or ModelSwitch candidate.
ModelSpec candidate_spec(const ExtensionRow& row, const Scene& scene, double extent);

// Placebos: the base plus k parameters that stand for no missing effect (initial velocity
// components the base leaves alone, those the body's motion does not use first), one for
// each count in `counts` (1..3).
std::vector<std::string> placebo_parameters(const Scene& scene, const std::vector<std::string>& base_fit);
ModelSpec placebo_spec(const Scene& scene, const std::vector<std::string>& spare, int k);

// Up to `most` planes the base fit asks for: directions (8 horizontal ones, up and down)
// along which the fitted body went, in some held-in frame, beyond every observed point by
// more than half a cell, counted from the same gap in the first observed frame (the part of
// the body no camera sees), at least 60 degrees apart, furthest first; none facing within 14
// degrees of a plane the scene has (that would be the plane's offset, not a second surface). Each spec adds the
// plane (facing back, where the observed body's extreme was) and fits its height.
std::vector<ModelSpec> plane_proposals(const FittedModel& base, int heldin, int most);

// The two-material body the stiffness gradient's fit asks for: a plane through the rest
// body's centre across the gradient, the side the gradient points to its own Young's modulus
// (material.regions[0]), about the gradient's mean modulus there. Not found when the gradient
// changes the modulus by less than 10 % across the body. interface_search.h refines it.
struct InterfaceGuess {
  Eigen::Vector3d normal = Eigen::Vector3d::Zero();  // unit; n . x = offset is the interface
  double offset = 0, modulus = 0;  // modulus: the side the normal points to
  double body_modulus = 0;          // the other side's; 0: the base fit's
  bool found() const { return normal.squaredNorm() > 0; }
};
InterfaceGuess interface_proposal(const FittedModel& gradient_fit, const Problem& base, double extent);
// The two-material model with the interface n . x = offset (n a unit vector; the side n points
// to has its own Young's modulus, started within 3 times `modulus` of it).
ModelSpec two_materials_spec(const Eigen::Vector3d& normal, double offset, double modulus, const std::string& note);

// The discretization controls: the base model on a finer discretization, no parameter of its
// own. What one removes of the held-out residual is the model's own discretization error,
// which no physical candidate stands for:
//   finer_grid  a grid of half the cell size (twice the resolution; the same band in metres);
//               not for an sdf_file body, whose grid is the file's
//   finer_step  half the time step (twice the steps)
const std::vector<std::string>& discretization_controls();
// Empty `name` (and why in `skipped`) where the discretization cannot be refined.
ModelSpec discretization_spec(const std::string& control, const Scene& scene, std::string* skipped);
ModelSpec finer_grid_spec(const Scene& scene, std::string* skipped);
ModelSpec finer_step_spec(const Scene& scene);

}  // namespace ssc
