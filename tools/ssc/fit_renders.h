// Pictures of a fit: for a few observed frames, the reconstructed body's surface seen
// from the first camera with the observed depth points drawn over it, coloured by their
// distance to the fitted surface (|phi| of the sparse surface constraint).
#pragma once
#include <Eigen/Core>
#include <string>
#include <vector>

#include "models/io/output_dir.h"
#include "models/sim/problem.h"

namespace ssc {

// Writes fit_frame_NNNN.svg files into out; returns their names.
std::vector<std::string> write_fit_renders(const OutputDir& out, const Problem& problem, const std::vector<std::string>& names,
                                           const Eigen::VectorXd& values);

}  // namespace ssc
