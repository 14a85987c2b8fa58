// The space an optimiser works in. Each physical parameter x is reached from an internal
// unbounded coordinate z, so that every value the optimiser can produce is valid:
//   positive (E, density, damping):  x = exp(z)                     (relative steps)
//   bounded (Poisson ratio, angles): x = lo + (hi - lo) sigmoid(z)  (never leaves [lo, hi])
//   free (gravity, velocities, heights): x = s z, s = a typical magnitude
// Explicit bounds [lo, hi] given for a parameter (a plausible range) make its axis bounded; a
// positive parameter's with lo > 0 then runs the sigmoid over log x, so that its steps stay
// relative: x = exp(log lo + (log hi - log lo) sigmoid(z)).
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
  bool logarithmic = false;     // Bounded: the sigmoid runs over log x (lower > 0)
  double scale = 1;             // Free
};

// The default axis of a named parameter (see models/sim/parameters.h for names).
ParameterAxis default_axis(const std::string& name, double nominal);

// `axis` limited to [lower, upper] (explicit bounds, a plausible range): bounded, within a
// bounded axis's own range; a positive axis logarithmic if lower > 0, else linear on [0, upper].
// An infinite upper end (or an infinite lower end of a free axis) leaves the axis as it is.
// InputError (naming the parameter) for a NaN or for bounds that leave no value.
ParameterAxis with_bounds(const ParameterAxis& axis, double lower, double upper);

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
