// The soft-min contact's potential (see contact_potential.h).
#include "models/sim/contact_potential.h"

#include <cmath>
#include <initializer_list>

namespace ssc {
namespace {

// -Li2(-x) = integral_0^x ln(1 + t) / t dt = x - x^2/4 + x^3/9 - ... for 0 <= x <= 1: the
// series where it converges fast (x <= 1/2; most contact points are far from the plane, x ~ 0),
// else 8-point Gauss-Legendre on [0, x] (the integrand is analytic for t > -1; about 1e-13).
double minus_dilog_of_minus(double x) {
  if (x <= 0.5) {
    double s = 0, power = x;
    for (int k = 1; k < 60 && power > 1e-17 * k * k; ++k, power *= x) s += (k % 2 ? power : -power) / (double(k) * k);
    return s;
  }
  static const double node[4] = {0.1834346424956498, 0.5255324099163290, 0.7966664774136267, 0.9602898564975363};
  static const double weight[4] = {0.3626837833783620, 0.3137066458778873, 0.2223810344533745, 0.1012285362903763};
  double s = 0;
  for (int i = 0; i < 4; ++i)
    for (double sign : {-1.0, 1.0}) {
      const double t = 0.5 * x * (1 + sign * node[i]);
      s += weight[i] * std::log1p(t) / t;
    }
  return 0.5 * x * s;
}

}  // namespace

double softmin_potential(double d, double alpha) {
  constexpr double kPiSquaredOver6 = 1.6449340668482264;
  const double y = alpha * d;
  if (y >= 0) return minus_dilog_of_minus(std::exp(-y)) / (alpha * alpha);
  return (kPiSquaredOver6 + 0.5 * y * y - minus_dilog_of_minus(std::exp(y))) / (alpha * alpha);
}

}  // namespace ssc
