// Cut-cell integration by sub-cubes and clipped tetrahedra (see cut_cell.h for the method).
// Everything is computed in the unit cell [0,1]^3 and scaled by h^3 (volumes) and h^2
// (areas) at the end. Quadrature rules (weights relative to the simplex measure):
//   tetrahedron, degree 3: centroid -4/5, the 4 points 1/2 v_i + 1/6 (others) 9/20 each;
//   triangle,    degree 3: centroid -27/48, the 3 points 3/5 v_i + 1/5 (others) 25/48 each.
// Both are exact for the trilinear N_c restricted to a tetrahedron or a plane (degree 3);
// the negative centroid weights do not matter for exact polynomial integration.
#include "models/grid/cut_cell.h"

#include "runtime/errors.h"

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

namespace ssc {
namespace {

using Vec3 = Eigen::Vector3d;

struct Accumulator {
  std::array<double, 8> volume{};
  std::array<double, 8> surface{};
};

// The 8 trilinear shape functions of the unit cell at x.
std::array<double, 8> shape_functions(const Vec3& x) {
  std::array<double, 8> n{};
  for (int c = 0; c < 8; ++c) {
    n[c] = ((c & 1) ? x.x() : 1 - x.x()) * ((c & 2) ? x.y() : 1 - x.y()) *
           ((c & 4) ? x.z() : 1 - x.z());
  }
  return n;
}

double trilinear(const std::array<double, 8>& phi, const Vec3& x) {
  const std::array<double, 8> n = shape_functions(x);
  double v = 0;
  for (int c = 0; c < 8; ++c) v += n[c] * phi[c];
  return v;
}

void add_weighted(std::array<double, 8>& acc, const Vec3& x, double w) {
  const std::array<double, 8> n = shape_functions(x);
  for (int c = 0; c < 8; ++c) acc[c] += w * n[c];
}

void add_tet_volume(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d,
                    Accumulator& acc) {
  const double vol = std::abs((b - a).dot((c - a).cross(d - a))) / 6.0;
  if (vol == 0) return;
  add_weighted(acc.volume, (a + b + c + d) / 4.0, -0.8 * vol);
  const double w = 0.45 * vol;
  add_weighted(acc.volume, 0.5 * a + (b + c + d) / 6.0, w);
  add_weighted(acc.volume, 0.5 * b + (a + c + d) / 6.0, w);
  add_weighted(acc.volume, 0.5 * c + (a + b + d) / 6.0, w);
  add_weighted(acc.volume, 0.5 * d + (a + b + c) / 6.0, w);
}

void add_triangle_surface(const Vec3& a, const Vec3& b, const Vec3& c, Accumulator& acc) {
  const double area = 0.5 * (b - a).cross(c - a).norm();
  if (area == 0) return;
  add_weighted(acc.surface, (a + b + c) / 3.0, -27.0 / 48.0 * area);
  const double w = 25.0 / 48.0 * area;
  add_weighted(acc.surface, 0.6 * a + 0.2 * (b + c), w);
  add_weighted(acc.surface, 0.6 * b + 0.2 * (a + c), w);
  add_weighted(acc.surface, 0.6 * c + 0.2 * (a + b), w);
}

// Prism with triangles (a0,a1,a2), (b0,b1,b2) and lateral edges a_i-b_i, as 3 tetrahedra.
void add_prism_volume(const Vec3& a0, const Vec3& a1, const Vec3& a2, const Vec3& b0,
                      const Vec3& b1, const Vec3& b2, Accumulator& acc) {
  add_tet_volume(a0, a1, a2, b2, acc);
  add_tet_volume(a0, a1, b1, b2, acc);
  add_tet_volume(a0, b0, b1, b2, acc);
}

// Zero crossing of the linear phi on the edge from p (phi <= 0) to q (phi > 0).
Vec3 crossing(const Vec3& p, double fp, const Vec3& q, double fq) {
  return p + (fp / (fp - fq)) * (q - p);
}

// Clips one tetrahedron (phi linear) by phi <= 0 and integrates volume and surface.
void integrate_tet(const std::array<Vec3, 4>& x, const std::array<double, 4>& f,
                   Accumulator& acc) {
  int in[4], out[4], n_in = 0, n_out = 0;
  for (int v = 0; v < 4; ++v) (f[v] <= 0 ? in[n_in++] : out[n_out++]) = v;
  auto cross = [&](int i, int o) { return crossing(x[i], f[i], x[o], f[o]); };
  switch (n_in) {
    case 0:
      return;
    case 4:
      add_tet_volume(x[0], x[1], x[2], x[3], acc);
      return;
    case 1: {
      const int i = in[0];
      const Vec3 p0 = cross(i, out[0]), p1 = cross(i, out[1]), p2 = cross(i, out[2]);
      add_tet_volume(x[i], p0, p1, p2, acc);
      add_triangle_surface(p0, p1, p2, acc);
      return;
    }
    case 2: {
      const int i = in[0], j = in[1], k = out[0], l = out[1];
      const Vec3 pik = cross(i, k), pil = cross(i, l), pjk = cross(j, k), pjl = cross(j, l);
      add_prism_volume(x[i], pik, pil, x[j], pjk, pjl, acc);
      add_triangle_surface(pik, pil, pjl, acc);
      add_triangle_surface(pik, pjl, pjk, acc);
      return;
    }
    default: {  // 3 inside, one outside
      const int o = out[0];
      const Vec3 q0 = cross(in[0], o), q1 = cross(in[1], o), q2 = cross(in[2], o);
      add_prism_volume(x[in[0]], x[in[1]], x[in[2]], q0, q1, q2, acc);
      add_triangle_surface(q0, q1, q2, acc);
      return;
    }
  }
}

// Closed form of the integral of N_c over the box [lo, hi] (a sub-cube entirely inside).
void add_box_volume(const Vec3& lo, const Vec3& hi, Accumulator& acc) {
  double rising[3], falling[3];  // integrals of x and (1 - x) per axis
  for (int a = 0; a < 3; ++a) {
    rising[a] = 0.5 * (hi[a] * hi[a] - lo[a] * lo[a]);
    falling[a] = (hi[a] - lo[a]) - rising[a];
  }
  for (int c = 0; c < 8; ++c) {
    acc.volume[c] += ((c & 1) ? rising[0] : falling[0]) * ((c & 2) ? rising[1] : falling[1]) *
                     ((c & 4) ? rising[2] : falling[2]);
  }
}

// Sub-cube (a,b,c) of an n^3 split: integrates its cut part through the 6 tetrahedra.
void integrate_sub_cube(const std::array<double, 8>& corner_phi, const Vec3& lo, double step,
                        Accumulator& acc) {
  double lo_phi = corner_phi[0], hi_phi = corner_phi[0];
  for (double v : corner_phi) lo_phi = std::min(lo_phi, v), hi_phi = std::max(hi_phi, v);
  if (lo_phi > 0) return;
  if (hi_phi <= 0) return add_box_volume(lo, lo + Vec3::Constant(step), acc);
  for (const auto& tet : kCellTetrahedra) {
    std::array<Vec3, 4> x;
    std::array<double, 4> f{};
    for (int v = 0; v < 4; ++v) {
      const int c = tet[v];
      x[v] = lo + step * Vec3(c & 1, (c >> 1) & 1, (c >> 2) & 1);
      f[v] = corner_phi[c];
    }
    integrate_tet(x, f, acc);
  }
}

Accumulator integrate_subdivided(const std::array<double, 8>& phi, int n) {
  const double step = 1.0 / n;
  const int m = n + 1;
  std::vector<double> lattice(size_t(m) * m * m);  // exact trilinear phi at sub-cube corners
  for (int k = 0; k < m; ++k)
    for (int j = 0; j < m; ++j)
      for (int i = 0; i < m; ++i)
        lattice[i + m * (j + m * k)] = trilinear(phi, Vec3(i, j, k) * step);
  Accumulator acc;
  for (int k = 0; k < n; ++k)
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i) {
        std::array<double, 8> corner_phi{};
        for (int c = 0; c < 8; ++c)
          corner_phi[c] =
              lattice[(i + (c & 1)) + m * ((j + ((c >> 1) & 1)) + m * (k + ((c >> 2) & 1)))];
        integrate_sub_cube(corner_phi, Vec3(i, j, k) * step, step, acc);
      }
  return acc;
}

void validate(const std::array<double, 8>& phi, double h, int subdivisions) {
  for (double v : phi)
    if (!std::isfinite(v))
      throw InputError("integrate_cut_cell: non-finite SDF value at a cell corner; "
                       "check the SDF grid for NaN/Inf");
  if (!(h > 0) || !std::isfinite(h))
    throw InputError("integrate_cut_cell: cell size h must be positive, got " +
                     std::to_string(h));
  if (subdivisions < 1)
    throw InputError("integrate_cut_cell: subdivisions must be >= 1, got " +
                     std::to_string(subdivisions));
}

}  // namespace

CutCellIntegrals integrate_cut_cell(const std::array<double, 8>& phi, double h,
                                    int subdivisions) {
  validate(phi, h, subdivisions);
  const auto [lo, hi] = std::minmax_element(phi.begin(), phi.end());
  CutCellIntegrals r;
  if (*lo > 0) return r;  // empty: trilinear phi >= min corner > 0
  const double h2 = h * h, h3 = h2 * h;
  if (*hi <= 0) {  // full: trilinear phi <= max corner <= 0
    r.volume.fill(h3 / 8);
    r.volume_total = h3;
    return r;
  }
  const Accumulator acc = integrate_subdivided(phi, subdivisions);
  for (int c = 0; c < 8; ++c) {
    r.volume[c] = acc.volume[c] * h3;
    r.surface[c] = acc.surface[c] * h2;
    r.volume_total += r.volume[c];
    r.area_total += r.surface[c];
  }
  return r;
}

}  // namespace ssc
