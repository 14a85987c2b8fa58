// The space an optimiser works in. Each physical parameter x is reached from an internal
// unbounded coordinate z, so that every value the optimiser can produce is valid:
//   positive (E, density, damping):  x = exp(z)                     (relative steps)
//   bounded (Poisson ratio, angles): x = lo + (hi - lo) sigmoid(z)  (never leaves [lo, hi])
//   free (gravity, velocities, heights): x = s z, s = a typical magnitude
// Gradients are carried over exactly: dJ/dz = dJ/dx dx/dz.
#pragma once
#include <Eigen/Core>
#include <string>
#include <vector>

namespace ssc {

struct ParameterAxis {
  std::string name;
  enum class Kind { Positive, Bounded, Free } kind = Kind::Free;
  double lower = 0, upper = 0;  // Bounded
  double scale = 1;             // Free
};

// The default axis of a named parameter (see models/sim/parameters.h for names).
ParameterAxis default_axis(const std::string& name, double nominal);

class ParameterSpace {
 public:
  explicit ParameterSpace(std::vector<ParameterAxis> axes) : axes_(std::move(axes)) {}
  int size() const { return int(axes_.size()); }
  const std::vector<ParameterAxis>& axes() const { return axes_; }

  Eigen::VectorXd to_internal(const Eigen::VectorXd& x) const;    // InputError if x is outside the axis
  Eigen::VectorXd to_physical(const Eigen::VectorXd& z) const;
  Eigen::VectorXd gradient_to_internal(const Eigen::VectorXd& z, const Eigen::VectorXd& dJ_dx) const;

 private:
  std::vector<ParameterAxis> axes_;
};

}  // namespace ssc
