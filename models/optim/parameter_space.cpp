// Parameter transforms (see parameter_space.h).
#include "models/optim/parameter_space.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "runtime/errors.h"
#include "models/sim/parameter_table.h"

namespace ssc {

// exp() of a larger argument overflows (or underflows to 0): positive values stay in
// [e^-700, e^700], far beyond any physical parameter.
constexpr double kMaxLog = 700;

ParameterAxis default_axis(const std::string& name, double nominal) {
  const ParameterRow row = parameter_row(name);
  ParameterAxis a;
  a.name = name;
  switch (row.transform) {
    case ParameterRow::Transform::Positive:
      a.kind = ParameterAxis::Kind::Positive;
      break;
    case ParameterRow::Transform::Bounded:
      a.kind = ParameterAxis::Kind::Bounded;
      a.lower = row.optimiser_lower;
      a.upper = row.optimiser_upper;
      break;
    case ParameterRow::Transform::Free:
      a.kind = ParameterAxis::Kind::Free;
      a.scale = std::max(std::abs(nominal), 1.0);
      break;
  }
  return a;
}

ParameterAxis with_bounds(const ParameterAxis& axis, double lower, double upper) {
  if (std::isnan(lower) || std::isnan(upper))
    throw InputError(fmt::format("bounds of {}: [{:g}, {:g}] must be numbers", axis.name, lower, upper));
  if (!std::isfinite(upper)) return axis;
  ParameterAxis a = axis;
  switch (axis.kind) {
    case ParameterAxis::Kind::Positive:
      a.logarithmic = lower > 0;
      lower = std::max(lower, 0.0);
      break;
    case ParameterAxis::Kind::Bounded:
      lower = std::max(lower, axis.lower), upper = std::min(upper, axis.upper);
      break;
    case ParameterAxis::Kind::Free:
      if (!std::isfinite(lower)) return axis;
      break;
  }
  if (!(lower < upper))
    throw InputError(fmt::format("bounds of {}: [{:g}, {:g}] leave no value{}", axis.name, lower, upper,
                                 axis.kind == ParameterAxis::Kind::Bounded
                                     ? fmt::format(" within its range [{:g}, {:g}]", axis.lower, axis.upper)
                                     : ""));
  a.kind = ParameterAxis::Kind::Bounded;
  a.lower = lower, a.upper = upper;
  return a;
}

Eigen::VectorXd ParameterSpace::to_internal(const Eigen::VectorXd& x) const {
  Eigen::VectorXd z(size());
  for (int i = 0; i < size(); ++i) {
    const ParameterAxis& a = axes_[i];
    switch (a.kind) {
      case ParameterAxis::Kind::Positive:
        if (!(x[i] > 0)) throw InputError(fmt::format("{} must be positive, found {}", a.name, x[i]));
        z[i] = std::log(x[i]);
        break;
      case ParameterAxis::Kind::Bounded: {
        if (!(x[i] > a.lower && x[i] < a.upper))
          throw InputError(fmt::format("{} must be strictly between {} and {}, found {}", a.name, a.lower, a.upper, x[i]));
        const double t = a.logarithmic ? std::log(x[i] / a.lower) / std::log(a.upper / a.lower)
                                       : (x[i] - a.lower) / (a.upper - a.lower);
        z[i] = std::log(t / (1 - t));
        break;
      }
      case ParameterAxis::Kind::Free:
        z[i] = x[i] / a.scale;
        break;
    }
  }
  return z;
}

Eigen::VectorXd ParameterSpace::to_physical(const Eigen::VectorXd& z) const {
  Eigen::VectorXd x(size());
  for (int i = 0; i < size(); ++i) {
    const ParameterAxis& a = axes_[i];
    switch (a.kind) {
      case ParameterAxis::Kind::Positive: x[i] = std::exp(std::clamp(z[i], -kMaxLog, kMaxLog)); break;
      case ParameterAxis::Kind::Bounded:
        x[i] = a.logarithmic ? std::clamp(a.lower * std::exp(std::log(a.upper / a.lower) / (1 + std::exp(-z[i]))), a.lower, a.upper)
                             : a.lower + (a.upper - a.lower) / (1 + std::exp(-z[i]));
        break;
      case ParameterAxis::Kind::Free: x[i] = a.scale * z[i]; break;
    }
  }
  return x;
}

Eigen::VectorXd ParameterSpace::gradient_to_internal(const Eigen::VectorXd& z, const Eigen::VectorXd& g) const {
  Eigen::VectorXd out(size());
  for (int i = 0; i < size(); ++i) {
    const ParameterAxis& a = axes_[i];
    switch (a.kind) {
      case ParameterAxis::Kind::Positive: out[i] = std::abs(z[i]) > kMaxLog ? 0.0 : g[i] * std::exp(z[i]); break;
      case ParameterAxis::Kind::Bounded: {
        const double s = 1 / (1 + std::exp(-z[i]));
        const double span = a.logarithmic ? std::log(a.upper / a.lower) * a.lower * std::exp(std::log(a.upper / a.lower) * s)
                                          : a.upper - a.lower;
        out[i] = g[i] * span * s * (1 - s);
        break;
      }
      case ParameterAxis::Kind::Free: out[i] = g[i] * a.scale; break;
    }
  }
  return out;
}

}  // namespace ssc
