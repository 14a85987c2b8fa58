// Sparse surface constraint cost and its adjoint (see surface_constraint.h).
#include "models/cost/surface_constraint.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#include "ops/trilinear.h"

namespace ssc {
namespace {

Vec3<double> node_point(const SimGrid& g, int kind, long grid_index, const double* u, const double* band_u) {
  const SdfGrid& s = g.sdf;
  const int i = int(grid_index % s.size.x()), j = int((grid_index / s.size.x()) % s.size.y());
  const int k = int(grid_index / (long(s.size.x()) * s.size.y()));
  const Eigen::Vector3d x = s.node_position(i, j, k);
  Vec3<double> d = kind >= 0 ? load3(u, kind) : load3(band_u, -kind - 2);
  return make_vec3(x.x() + d.x, x.y() + d.y, x.z() + d.z);
}

// Uniform bins over the deformed cells' bounding boxes, and the boxes themselves (a point
// outside a cell's box is outside the cell: the trilinear image of [0,1]^3 lies in the
// convex hull of the corners).
struct BinGrid {
  Eigen::Vector3d lo;
  double size = 1;
  Eigen::Vector3i n;
  std::vector<int> offset, entry;
  std::vector<Eigen::AlignedBox3d> boxes;  // per cell, grown by a margin for the match slack

  bool bin_of(const Eigen::Vector3d& p, long* index) const {
    Eigen::Vector3i b;
    for (int d = 0; d < 3; ++d) {
      const double q = std::floor((p[d] - lo[d]) / size);
      if (q < 0 || q >= n[d]) return false;
      b[d] = int(q);
    }
    *index = b.x() + long(n.x()) * (b.y() + long(n.y()) * b.z());
    return true;
  }
};

BinGrid build_bins(const std::vector<std::array<Vec3<double>, 8>>& X, double size) {
  BinGrid bins;
  Eigen::AlignedBox3d all;
  std::vector<Eigen::AlignedBox3d> boxes(X.size());
  for (size_t c = 0; c < X.size(); ++c) {
    for (const Vec3<double>& x : X[c]) boxes[c].extend(Eigen::Vector3d(x.x, x.y, x.z));
    all.extend(boxes[c]);
  }
  bins.lo = all.min();
  // The match accepts local coordinates up to 1e-9 outside [0,1]^3; the margin covers that.
  bins.boxes = boxes;
  for (Eigen::AlignedBox3d& b : bins.boxes)
    if (!b.isEmpty()) {
      const double margin = 1e-6 * (b.sizes().norm() + 1e-3 * size);
      b.extend(Eigen::Vector3d(b.min().array() - margin)).extend(Eigen::Vector3d(b.max().array() + margin));
    }
  if (X.empty() || !all.sizes().allFinite()) {  // nothing to match against
    bins.size = size;
    bins.n = Eigen::Vector3i::Ones();
    bins.offset.assign(2, 0);
    return bins;
  }
  // Bins of one cell size, coarser when the deformed cells spread far (a diverging start of a
  // reconstruction): at most 8 bins per cell in all.
  const double cap = 8.0 * double(X.size()) + 64.0;
  auto bins_for = [&](double s) {
    double t = 1;
    for (int d = 0; d < 3; ++d) t *= std::floor(all.sizes()[d] / s) + 1;
    return t;
  };
  bins.size = size;
  while (bins_for(bins.size) > cap) bins.size *= 1.25;
  for (int d = 0; d < 3; ++d) bins.n[d] = int(std::floor(all.sizes()[d] / bins.size)) + 1;
  size = bins.size;
  const long total = long(bins.n.x()) * bins.n.y() * bins.n.z();
  std::vector<int> count(total + 1, 0);
  auto range = [&](const Eigen::AlignedBox3d& b, Eigen::Vector3i& lo, Eigen::Vector3i& hi) {
    for (int d = 0; d < 3; ++d) {
      lo[d] = std::clamp(int(std::floor((b.min()[d] - bins.lo[d]) / size)), 0, bins.n[d] - 1);
      hi[d] = std::clamp(int(std::floor((b.max()[d] - bins.lo[d]) / size)), 0, bins.n[d] - 1);
    }
  };
  for (int pass = 0; pass < 2; ++pass) {
    for (size_t c = 0; c < X.size(); ++c) {
      Eigen::Vector3i lo, hi;
      range(boxes[c], lo, hi);
      for (int z = lo.z(); z <= hi.z(); ++z)
        for (int y = lo.y(); y <= hi.y(); ++y)
          for (int x = lo.x(); x <= hi.x(); ++x) {
            const long bin = x + long(bins.n.x()) * (y + long(bins.n.y()) * z);
            if (pass == 0)
              ++count[bin + 1];
            else
              bins.entry[count[bin]++] = int(c);
          }
    }
    if (pass == 0) {
      for (long b = 0; b < total; ++b) count[b + 1] += count[b];
      bins.offset = count;
      bins.entry.resize(count[total]);
    }
  }
  return bins;
}

}  // namespace

SurfaceConstraintCost::SurfaceConstraintCost(const SimGrid& grid, double phi_max) : grid_(grid), phi_max_(phi_max) {
  const SdfGrid& s = grid.sdf;
  const long nx = s.size.x(), nxy = nx * s.size.y();
  for (int k = 0; k + 1 < s.size.z(); ++k)
    for (int j = 0; j + 1 < s.size.y(); ++j)
      for (int i = 0; i + 1 < s.size.x(); ++i) {
        const long o = s.index(i, j, k);
        std::array<int, 8> kinds;
        bool ok = true;
        for (int c = 0; c < 8; ++c) {
          kinds[c] = grid.grid_kind[o + (c & 1) + ((c >> 1) & 1) * nx + ((c >> 2) & 1) * nxy];
          ok &= kinds[c] != -1;
        }
        if (!ok) continue;
        cells_.push_back(o);
        corners_.push_back(kinds);
      }
}

std::vector<SurfaceConstraintCost::Match> SurfaceConstraintCost::match_points(const std::vector<Eigen::Vector3d>& points,
                                                                              const double* u,
                                                                              const double* band_u) const {
  const SdfGrid& s = grid_.sdf;
  const long nx = s.size.x(), nxy = nx * s.size.y();
  std::vector<std::array<Vec3<double>, 8>> X(cells_.size());
  for (size_t c = 0; c < cells_.size(); ++c)
    for (int k = 0; k < 8; ++k)
      X[c][k] = node_point(grid_, corners_[c][k], cells_[c] + (k & 1) + ((k >> 1) & 1) * nx + ((k >> 2) & 1) * nxy, u, band_u);
  const BinGrid bins = build_bins(X, grid_.h);
  const double tol = 1e-10 * grid_.h, slack = 1e-9;
  std::vector<Match> matches(points.size());
#pragma omp parallel for schedule(dynamic, 64)
  for (long i = 0; i < long(points.size()); ++i) {
    long bin;
    if (!bins.bin_of(points[i], &bin)) continue;
    const Vec3<double> p = make_vec3(points[i].x(), points[i].y(), points[i].z());
    Match best;
    for (int k = bins.offset[bin]; k < bins.offset[bin + 1]; ++k) {
      const int c = bins.entry[k];
      if (!bins.boxes[c].contains(points[i])) continue;
      Vec3<double> abc;
      if (!ops::trilinear_inverse(X[c].data(), p, tol, abc)) continue;
      if (abc.x < -slack || abc.x > 1 + slack || abc.y < -slack || abc.y > 1 + slack || abc.z < -slack || abc.z > 1 + slack)
        continue;
      double phi[8];
      for (int q = 0; q < 8; ++q) phi[q] = s.phi[cells_[c] + (q & 1) + ((q >> 1) & 1) * nx + ((q >> 2) & 1) * nxy];
      const double value = ops::trilinear_scalar(phi, abc);
      if (best.cell < 0 || std::abs(value) < std::abs(best.phi) || (std::abs(value) == std::abs(best.phi) && c < best.cell))
        best = {c, abc.x, abc.y, abc.z, value};
    }
    matches[i] = best;
  }
  return matches;
}

FrameCost SurfaceConstraintCost::evaluate(const std::vector<Eigen::Vector3d>& points, double weight, const double* u,
                                          const double* band_u, double* u_bar, double* band_bar) const {
  return evaluate_impl(points, nullptr, weight, u, band_u, u_bar, band_bar);
}

FrameCost SurfaceConstraintCost::evaluate_targets(const std::vector<Eigen::Vector3d>& points,
                                                  const std::vector<double>& targets, double weight, const double* u,
                                                  const double* band_u, double* u_bar, double* band_bar) const {
  return evaluate_impl(points, &targets, weight, u, band_u, u_bar, band_bar);
}

FrameCost SurfaceConstraintCost::evaluate_impl(const std::vector<Eigen::Vector3d>& points,
                                               const std::vector<double>* targets, double weight, const double* u,
                                               const double* band_u, double* u_bar, double* band_bar) const {
  FrameCost r;
  r.points = int(points.size());
  if (points.empty()) return r;
  const std::vector<Match> matches = match_points(points, u, band_u);
  const SdfGrid& s = grid_.sdf;
  const long nx = s.size.x(), nxy = nx * s.size.y();
  const double scale = weight / double(points.size());
  double sum = 0;
  for (size_t i = 0; i < points.size(); ++i) {
    const Match& m = matches[i];
    const bool targeted = targets != nullptr;
    if (targeted && (m.cell < 0 || std::isnan((*targets)[i]))) continue;
    if (m.cell < 0) {
      sum += 0.5 * phi_max_ * phi_max_;
      continue;
    }
    ++r.matched;
    const double residual = targeted ? m.phi - (*targets)[i] : 0.0;
    sum += targeted ? 0.5 * residual * residual : ops::surface_point_cost(m.phi, phi_max_);
    if (!u_bar) continue;
    Vec3<double> X[8], X_bar[8];
    double phi[8];
    for (int k = 0; k < 8; ++k) {
      const long n = cells_[m.cell] + (k & 1) + ((k >> 1) & 1) * nx + ((k >> 2) & 1) * nxy;
      X[k] = node_point(grid_, corners_[m.cell][k], n, u, band_u);
      phi[k] = s.phi[n];
      X_bar[k] = zero3<double>();
    }
    const double phi_bar = scale * (targeted ? residual : ops::surface_point_cost_derivative(m.phi, phi_max_));
    ops::adj_inverse_then_interpolate(X, make_vec3(m.a, m.b, m.c), phi, phi_bar, X_bar);
    for (int k = 0; k < 8; ++k) {
      const int kind = corners_[m.cell][k];
      if (kind >= 0)
        add3(u_bar, kind, X_bar[k]);
      else
        add3(band_bar, -kind - 2, X_bar[k]);
    }
  }
  r.cost = scale * sum;
  return r;
}

std::vector<double> SurfaceConstraintCost::point_phi(const std::vector<Eigen::Vector3d>& points, const double* u,
                                                     const double* band_u) const {
  std::vector<double> out;
  for (const Match& m : match_points(points, u, band_u))
    out.push_back(m.cell < 0 ? std::numeric_limits<double>::quiet_NaN() : m.phi);
  return out;
}

}  // namespace ssc

namespace ssc {

std::vector<SurfaceConstraintCost::PointResidual> SurfaceConstraintCost::point_residuals(
    const std::vector<Eigen::Vector3d>& points, const double* u, const double* band_u) const {
  const SdfGrid& s = grid_.sdf;
  const long nx = s.size.x(), nxy = nx * s.size.y();
  const std::vector<Match> matches = match_points(points, u, band_u);
  std::vector<PointResidual> out(points.size());
  for (size_t i = 0; i < points.size(); ++i) {
    const Match& m = matches[i];
    if (m.cell < 0) continue;
    Vec3<double> X[8], X0[8];
    double phi[8];
    for (int k = 0; k < 8; ++k) {
      const long n = cells_[m.cell] + (k & 1) + ((k >> 1) & 1) * nx + ((k >> 2) & 1) * nxy;
      X[k] = node_point(grid_, corners_[m.cell][k], n, u, band_u);
      const Eigen::Vector3d r = s.node_position(n);
      X0[k] = make_vec3(r.x(), r.y(), r.z());
      phi[k] = s.phi[n];
    }
    const Vec3<double> abc = make_vec3(m.a, m.b, m.c);
    Vec3<double> dphi = zero3<double>();  // d phi / d abc
    for (int k = 0; k < 8; ++k) dphi += phi[k] * ops::trilinear_weight_gradient(abc, k);
    // d phi / dx = J^-T d phi / d abc, J = dx / d abc of the deformed cell.
    const Vec3<double> g = mul_transposed(inverse(ops::trilinear_jacobian(X, abc)), dphi);
    const Vec3<double> rest = ops::trilinear_point(X0, abc);
    PointResidual& r = out[i];
    r.phi = m.phi;
    r.rest = Eigen::Vector3d(rest.x, rest.y, rest.z);
    const double len = norm(g);
    if (len > 0) r.normal = Eigen::Vector3d(g.x / len, g.y / len, g.z / len);
  }
  return out;
}

}  // namespace ssc
