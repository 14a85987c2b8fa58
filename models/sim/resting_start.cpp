// The resting-start check (see resting_start.h): a rigid, one-dimensional model of the body
// on each plane, solved by bisection.
#include "models/sim/resting_start.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <vector>

#include "models/sim/contact_potential.h"
#include "models/sim/simulation.h"
#include "ops/contact.h"

namespace ssc {
namespace {

// The contact points' rest distances to one plane and what the contact does with the body
// moved by s along the normal.
struct PlaneContact {
  std::vector<double> distance, area;
  double stiffness = 0, alpha = 0;

  double push(double s) const {  // N, along the normal
    double f = 0;
    for (std::size_t i = 0; i < distance.size(); ++i) f -= stiffness * area[i] * ops::softmin(distance[i] + s, alpha);
    return f;
  }
  double potential(double s) const {  // J
    double e = 0;
    for (std::size_t i = 0; i < distance.size(); ++i) e += stiffness * area[i] * softmin_potential(distance[i] + s, alpha);
    return e;
  }
};

// The s where the increasing function f crosses 0, searched from `from` in the direction
// `step` (doubling it until f changes sign), then bisected.
double crossing(const std::function<double(double)>& f, double from, double step) {
  double a = from, b = from + step;
  const bool rising = step > 0;
  for (int k = 0; k < 80 && (rising ? f(b) < 0 : f(b) > 0); ++k) {
    a = b;
    step *= 2;
    b = from + step;
  }
  double lo = std::min(a, b), hi = std::max(a, b);
  for (int k = 0; k < 200 && hi - lo > 1e-12 * std::max(1.0, std::abs(lo)); ++k) {
    const double mid = 0.5 * (lo + hi);
    (f(mid) < 0 ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

}  // namespace

std::vector<RestingStart> resting_start_jumps(const SimGrid& grid, const PhysicalParameters& p,
                                              const std::vector<char>& fixed_nodes) {
  std::vector<RestingStart> jumps;
  for (char fixed : fixed_nodes)
    if (fixed) return jumps;  // held in place: the rigid model does not apply
  double volume = 0;
  for (double v : grid.node_volume) volume += v;
  const double mass = p.density * volume;
  for (std::size_t k = 0; k < p.planes.size(); ++k) {
    const PlaneSpec& plane = p.planes[k];
    const Eigen::Vector3d n = plane.normal.normalized();
    const double weight = -mass * p.gravity.dot(n);
    if (plane.stiffness <= 0 || !(weight > 0) || grid.contact_points.empty()) continue;
    PlaneContact c;
    c.stiffness = plane.stiffness;
    c.alpha = plane.softmin_alpha;
    for (const ContactPoint& q : grid.contact_points) {
      const Eigen::Vector3d x = grid.point_start(q);
      c.distance.push_back(n.dot(x) - plane.height);
      c.area.push_back(q.area);
    }
    RestingStart r;
    r.plane = int(k);
    r.push = c.push(0);
    r.weight = weight;
    r.lowest = *std::min_element(c.distance.begin(), c.distance.end());
    const double target = kRestingReachFraction * weight;
    if (r.push < target) continue;  // out of reach: a drop, not a resting start
    const double scale = 1 / c.alpha;
    r.reach = r.lowest + crossing([&](double s) { return target - c.push(s); }, 0, scale);
    r.equilibrium = crossing([&](double s) { return weight - c.push(s); }, 0, r.push > weight ? scale : -scale);
    const double v = p.linear_velocity.dot(n);
    const double energy = c.potential(0) + 0.5 * mass * v * v;
    auto above_start = [&](double s) { return c.potential(s) + weight * s - energy; };
    // The far turning point lies beyond the equilibrium, where the energy rises again.
    r.excursion = r.equilibrium > 0 ? crossing(above_start, r.equilibrium, scale)
                                    : crossing([&](double s) { return -above_start(s); }, r.equilibrium, -scale);
    if (std::abs(r.excursion) > kRestingStartTolerance) jumps.push_back(r);
  }
  return jumps;
}

std::string resting_start_message(const RestingStart& r, const PhysicalParameters& p) {
  const PlaneSpec& plane = p.planes[std::size_t(r.plane)];
  const Eigen::Vector3d n = plane.normal.normalized();
  return fmt::format(
      "the body starts {:.3g} m {} ground plane {} (height {:g} m, normal [{:.3g}, {:.3g}, {:.3g}]), within the reach "
      "of its soft-min contact ({:.3g} m, where the push falls to {:.0f} % of the weight; the contact acts before "
      "touching, the more so the larger ground.stiffness / ground.softmin_alpha): it pushes with {:.3g} N against a "
      "weight of {:.3g} N, so the body does not start at rest. It will {} by up to {:.3g} m (rigid estimate without "
      "damping) and settle {:.3g} m {} its start. For a resting start, set ground.planes[{}].height to {:.6g} (the "
      "contact's equilibrium under gravity; the body stays where the observations show it), or move the object by "
      "{:.3g} m along the plane's normal (which resamples its grid)",
      std::abs(r.lowest), r.lowest >= 0 ? "above" : "inside", r.plane, plane.height, n.x(), n.y(), n.z(), r.reach,
      100 * kRestingReachFraction, r.push, r.weight, r.excursion > 0 ? "be thrown off the plane" : "sink into it",
      std::abs(r.excursion), std::abs(r.equilibrium), r.equilibrium > 0 ? "above" : "below", r.plane,
      plane.height - r.equilibrium, r.equilibrium);
}

}  // namespace ssc
