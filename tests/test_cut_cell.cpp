// Tests of the cut-cell integrator (models/grid/cut_cell), the marching-tetrahedra surface
// (models/grid/marching_tets) and the PLY writer (models/io/ply_writer).
//
// References: exact closed forms where phi is linear (the tetrahedral linearisation is then
// exact), a 200^3 midpoint sampling of the trilinear field for random cells, the integrator
// itself at a very fine subdivision for surface integrals, and a sphere for whole grids.
#include "models/geometry/sdf_grid.h"
#include "models/grid/cut_cell.h"
#include "models/grid/marching_tets.h"
#include "runtime/errors.h"
#include "models/io/ply_writer.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <random>
#include <sstream>
#include <string>
#include <utility>
#include <unistd.h>

namespace ssc {
namespace {

using Vec3 = Eigen::Vector3d;
using CornerPhi = std::array<double, 8>;

Vec3 corner_position(int c) { return Vec3(c & 1, (c >> 1) & 1, (c >> 2) & 1); }

// Corner values of f(unit coordinates), in metres for a cell of size h.
CornerPhi corners_of(const std::function<double(const Vec3&)>& f, double h) {
  CornerPhi phi{};
  for (int c = 0; c < 8; ++c) phi[c] = h * f(corner_position(c));
  return phi;
}

double sum(const std::array<double, 8>& a) {
  double s = 0;
  for (double v : a) s += v;
  return s;
}

// --- full, empty, planar cells --------------------------------------------------------------

TEST(CutCellIntegrals, FullAndEmptyCellsAreExact) {
  const double h = 0.37;
  for (const CornerPhi& phi : {CornerPhi{-1, -2, -0.5, -3, -1, -1, -0.1, -2},
                               CornerPhi{0, 0, 0, 0, 0, 0, 0, 0}, CornerPhi{-1, 0, 0, -1, 0, 0, -2, 0}}) {
    const CutCellIntegrals r = integrate_cut_cell(phi, h);
    for (int c = 0; c < 8; ++c) {
      EXPECT_EQ(r.volume[c], h * h * h / 8);
      EXPECT_EQ(r.surface[c], 0.0);
    }
    EXPECT_EQ(r.volume_total, h * h * h);
    EXPECT_EQ(r.area_total, 0.0);
  }
  const CutCellIntegrals e = integrate_cut_cell({1e-9, 2, 0.5, 3, 1, 1, 0.1, 2}, h);
  for (int c = 0; c < 8; ++c) {
    EXPECT_EQ(e.volume[c], 0.0);
    EXPECT_EQ(e.surface[c], 0.0);
  }
  EXPECT_EQ(e.volume_total, 0.0);
  EXPECT_EQ(e.area_total, 0.0);
}

TEST(CutCellIntegrals, RejectsBadInput) {
  const CornerPhi ok{-1, 1, 1, 1, 1, 1, 1, 1};
  EXPECT_THROW(integrate_cut_cell(ok, 0.0), InputError);
  EXPECT_THROW(integrate_cut_cell(ok, 1.0, 0), InputError);
  CornerPhi bad = ok;
  bad[3] = std::nan("");
  EXPECT_THROW(integrate_cut_cell(bad, 1.0), InputError);
}

TEST(CutCellIntegrals, TetrahedraArePositivelyOrientedAndFillTheCell) {
  double total = 0;
  for (const auto& t : kCellTetrahedra) {
    const Vec3 a = corner_position(t[0]);
    const double det =
        (corner_position(t[1]) - a).dot((corner_position(t[2]) - a).cross(corner_position(t[3]) - a));
    EXPECT_NEAR(det, 1.0, 1e-15);
    EXPECT_EQ(t[0], 0);
    EXPECT_EQ(t[3], 7);
    total += det / 6;
  }
  EXPECT_NEAR(total, 1.0, 1e-15);
}

// phi = s*(x_axis - a) (unit coordinates): the body is the slab x_axis <= a (s > 0) or >= a.
TEST(CutCellIntegrals, AxisPlaneCutsMatchClosedForm) {
  const double h = 0.25, a = 0.3;
  for (int axis = 0; axis < 3; ++axis)
    for (double s : {1.0, -1.0})
      for (int n : {1, 3, 4}) {
        const CornerPhi phi = corners_of([&](const Vec3& x) { return s * (x[axis] - a); }, h);
        const CutCellIntegrals r = integrate_cut_cell(phi, h, n);
        const double lo = s > 0 ? 0 : a, hi = s > 0 ? a : 1;
        for (int c = 0; c < 8; ++c) {
          const bool bit = (c >> axis) & 1;
          const double rising = 0.5 * (hi * hi - lo * lo), along = bit ? rising : (hi - lo) - rising;
          const double on_plane = bit ? a : 1 - a;
          EXPECT_NEAR(r.volume[c], along / 4 * h * h * h, 1e-12 * h * h * h) << axis << s << n << c;
          EXPECT_NEAR(r.surface[c], on_plane / 4 * h * h, 1e-12 * h * h) << axis << s << n << c;
        }
        EXPECT_NEAR(r.volume_total, (hi - lo) * h * h * h, 1e-12 * h * h * h);
        EXPECT_NEAR(r.area_total, h * h, 1e-12 * h * h);
      }
}

// Oblique corner cut x + y + z <= s around corner 0 (or its mirror image around corner 7).
// Integrals of a product of k distinct coordinates (k = 0..3), from the Dirichlet moments
// of a simplex: over the corner tetrahedron s^3/6, s^4/24, s^5/120, s^6/720; over the cut
// triangle (area A) A, A s/3, A s^2/12, A s^3/60.
TEST(CutCellIntegrals, ObliqueCornerCutMatchesClosedForm) {
  const double h = 0.5, s = 0.6, area = std::sqrt(3.0) / 2 * s * s;
  const double vol_moment[4] = {s * s * s / 6, std::pow(s, 4) / 24, std::pow(s, 5) / 120,
                                std::pow(s, 6) / 720};
  const double surf_moment[4] = {area, area * s / 3, area * s * s / 12, area * s * s * s / 60};
  for (bool mirrored : {false, true})
    for (int n : {1, 2, 5}) {
      const CornerPhi phi = corners_of(
          [&](const Vec3& x) {
            const Vec3 y = mirrored ? Vec3(Vec3::Ones() - x) : x;
            return (y.sum() - s) / std::sqrt(3.0);
          },
          h);
      const CutCellIntegrals r = integrate_cut_cell(phi, h, n);
      for (int c = 0; c < 8; ++c) {
        // In the (possibly mirrored) coordinates y, N_c is a product of y or (1 - y) factors;
        // expand it over subsets of the axes that take the y factor.
        const int cm = mirrored ? 7 - c : c;
        double vol = 0, surf = 0;
        for (int subset = 0; subset < 8; ++subset) {
          double coef = 1;
          int k = 0;
          for (int axis = 0; axis < 3; ++axis) {
            const bool bit = (cm >> axis) & 1, take_y = (subset >> axis) & 1;
            if (take_y) ++k, coef *= bit ? 1 : -1;
            else coef *= bit ? 0 : 1;
          }
          vol += coef * vol_moment[k];
          surf += coef * surf_moment[k];
        }
        EXPECT_NEAR(r.volume[c], vol * std::pow(h, 3), 1e-12 * std::pow(h, 3)) << c << n;
        EXPECT_NEAR(r.surface[c], surf * h * h, 1e-12 * h * h) << c << n;
      }
      EXPECT_NEAR(r.volume_total, vol_moment[0] * std::pow(h, 3), 1e-12 * std::pow(h, 3));
      EXPECT_NEAR(r.area_total, area * h * h, 1e-12 * h * h);
    }
}

// --- random trilinear cells -----------------------------------------------------------------

// Portable uniform numbers in [-1, 1) from mt19937's specified output sequence.
CornerPhi random_cut_cell(std::mt19937& gen) {
  for (;;) {
    CornerPhi phi{};
    for (double& v : phi) v = 2.0 * (gen() / 4294967296.0) - 1.0;
    const auto [lo, hi] = std::minmax_element(phi.begin(), phi.end());
    if (*lo < -0.2 && *hi > 0.2) return phi;
  }
}

// Midpoint sampling of the unit cell: integral of N_c over {trilinear phi <= 0}.
std::array<double, 8> sampled_volume(const CornerPhi& phi, int samples) {
  std::array<double, 8> acc{};
  const double d = 1.0 / samples;
  for (int k = 0; k < samples; ++k) {
    const double z = (k + 0.5) * d;
    for (int j = 0; j < samples; ++j) {
      const double y = (j + 0.5) * d;
      // phi is linear in x along the row: phi(x) = p0 + x (p1 - p0).
      const double wyz[4] = {(1 - y) * (1 - z), y * (1 - z), (1 - y) * z, y * z};
      double p0 = 0, p1 = 0;
      for (int q = 0; q < 4; ++q) p0 += wyz[q] * phi[2 * q], p1 += wyz[q] * phi[2 * q + 1];
      for (int i = 0; i < samples; ++i) {
        const double x = (i + 0.5) * d;
        if (p0 + x * (p1 - p0) > 0) continue;
        for (int q = 0; q < 4; ++q) acc[2 * q] += wyz[q] * (1 - x), acc[2 * q + 1] += wyz[q] * x;
      }
    }
  }
  for (double& v : acc) v *= d * d * d;
  return acc;
}

double max_abs_diff(const std::array<double, 8>& a, const std::array<double, 8>& b) {
  double m = 0;
  for (int c = 0; c < 8; ++c) m = std::max(m, std::abs(a[c] - b[c]));
  return m;
}

// SDF-like cell: distance to a sphere of radius 1.5..4 cells whose surface passes near the
// cell centre (unit coordinates; the typical content of a real cut cell).
CornerPhi sdf_like_cut_cell(std::mt19937& gen) {
  auto uniform = [&] { return 2.0 * (gen() / 4294967296.0) - 1.0; };
  for (;;) {
    Vec3 n(uniform(), uniform(), uniform());
    if (n.norm() < 0.1) continue;
    n.normalize();
    const double radius = 2.75 + 1.25 * uniform(), offset = 0.4 * uniform();
    const Vec3 centre = Vec3::Constant(0.5) + (offset - radius) * n;
    const CornerPhi phi = corners_of([&](const Vec3& x) { return (x - centre).norm() - radius; }, 1);
    const auto [lo, hi] = std::minmax_element(phi.begin(), phi.end());
    if (*lo < 0 && *hi > 0) return phi;
  }
}

// Worst per-corner errors over the cells, for subdivisions 1, 2, 4, 8, 16, in units of h^3
// (volume; reference: 200^3 midpoint sampling) and h^2 (surface; reference: the integrator
// with 128 subdivisions, whose own error is ~1/64^2 of that at the default 4).
struct ConvergenceTable {
  static constexpr int kLevels = 5;
  int subdivisions[kLevels] = {1, 2, 4, 8, 16};
  double volume[kLevels] = {}, surface[kLevels] = {};
};

ConvergenceTable measure_convergence(const std::vector<CornerPhi>& cells, double h) {
  ConvergenceTable t;
  const double h2 = h * h, h3 = h2 * h;
  for (const CornerPhi& unit_phi : cells) {
    CornerPhi phi = unit_phi;
    for (double& v : phi) v *= h;
    std::array<double, 8> ref_vol = sampled_volume(unit_phi, 200);
    for (double& v : ref_vol) v *= h3;
    const CutCellIntegrals fine = integrate_cut_cell(phi, h, 128);
    // The two independent references agree far below the errors measured here.
    EXPECT_LT(max_abs_diff(fine.volume, ref_vol) / h3, 2e-5);
    for (int m = 0; m < ConvergenceTable::kLevels; ++m) {
      const CutCellIntegrals r = integrate_cut_cell(phi, h, t.subdivisions[m]);
      t.volume[m] = std::max(t.volume[m], max_abs_diff(r.volume, ref_vol) / h3);
      t.surface[m] = std::max(t.surface[m], max_abs_diff(r.surface, fine.surface) / h2);
      EXPECT_NEAR(r.volume_total, sum(r.volume), 1e-15 * h3);
      EXPECT_NEAR(r.area_total, sum(r.surface), 1e-15 * h2);
    }
  }
  for (int m = 0; m < ConvergenceTable::kLevels; ++m)
    std::printf("  subdivisions %2d: max corner error volume %.2e h^3, surface %.2e h^2\n",
                t.subdivisions[m], t.volume[m], t.surface[m]);
  return t;
}

// Second order: each doubling of the subdivisions gains about 4 (asserted: more than 2.5).
void expect_second_order(const ConvergenceTable& t) {
  for (int m = 0; m + 1 < ConvergenceTable::kLevels; ++m) {
    EXPECT_LT(t.volume[m + 1], t.volume[m] / 2.5) << t.subdivisions[m + 1];
    EXPECT_LT(t.surface[m + 1], t.surface[m] / 2.5) << t.subdivisions[m + 1];
  }
}

// Arbitrary corner values in [-1, 1]: saddles and strongly curved level sets, the worst case.
TEST(CutCellIntegrals, RandomTrilinearCellsConvergeSecondOrder) {
  std::mt19937 gen(20240611u);
  std::vector<CornerPhi> cells;
  for (int trial = 0; trial < 4; ++trial) cells.push_back(random_cut_cell(gen));
  const ConvergenceTable t = measure_convergence(cells, 0.1);
  expect_second_order(t);
  EXPECT_LT(t.volume[2], 5e-3);  // the default, 4 subdivisions
  EXPECT_LT(t.surface[2], 3e-2);
}

// Cells of a distance field (|grad phi| = 1, curvature radius 1.5..4 cells): the default
// subdivision reaches 1e-3 of the cell volume per corner.
TEST(CutCellIntegrals, SdfLikeCellsReachTolerableErrorAtDefault) {
  std::mt19937 gen(77u);
  std::vector<CornerPhi> cells;
  for (int trial = 0; trial < 4; ++trial) cells.push_back(sdf_like_cut_cell(gen));
  const ConvergenceTable t = measure_convergence(cells, 0.1);
  expect_second_order(t);
  EXPECT_LT(t.volume[2], 1e-3);
  EXPECT_LT(t.surface[2], 2e-3);
}

// --- whole grids: a sphere ------------------------------------------------------------------

SdfGrid sphere_grid(double radius, const Vec3& centre, double h) {
  SdfGrid g;
  g.cell_size = h;
  const int cells = int(std::ceil(2 * radius / h)) + 4;
  g.origin = centre - Vec3::Constant((cells * h) / 2) + Vec3(0.011, -0.007, 0.003) * h;
  g.size = Eigen::Vector3i::Constant(cells + 1);
  g.phi.resize(g.node_count());
  for (int k = 0; k < g.size.z(); ++k)
    for (int j = 0; j < g.size.y(); ++j)
      for (int i = 0; i < g.size.x(); ++i)
        g.phi[g.index(i, j, k)] = (g.node_position(i, j, k) - centre).norm() - radius;
  return g;
}

CornerPhi cell_phi(const SdfGrid& g, int i, int j, int k) {
  CornerPhi phi{};
  for (int c = 0; c < 8; ++c) phi[c] = g.at(i + (c & 1), j + ((c >> 1) & 1), k + ((c >> 2) & 1));
  return phi;
}

struct GridTotals {
  double volume = 0, area = 0;
};

GridTotals integrate_grid(const SdfGrid& g, int subdivisions) {
  GridTotals t;
  for (int k = 0; k + 1 < g.size.z(); ++k)
    for (int j = 0; j + 1 < g.size.y(); ++j)
      for (int i = 0; i + 1 < g.size.x(); ++i) {
        const CutCellIntegrals r = integrate_cut_cell(cell_phi(g, i, j, k), g.cell_size, subdivisions);
        t.volume += sum(r.volume);
        t.area += sum(r.surface);
      }
  return t;
}

std::vector<long> sign_change_cells(const SdfGrid& g) {
  std::vector<long> cells;
  for (int k = 0; k + 1 < g.size.z(); ++k)
    for (int j = 0; j + 1 < g.size.y(); ++j)
      for (int i = 0; i + 1 < g.size.x(); ++i) {
        const CornerPhi phi = cell_phi(g, i, j, k);
        const auto [lo, hi] = std::minmax_element(phi.begin(), phi.end());
        if (*lo <= 0 && *hi > 0) cells.push_back(g.index(i, j, k));
      }
  return cells;
}

TEST(CutCellSphere, GridSumsGiveSphereVolumeAndArea) {
  const double r = 0.3, pi = std::acos(-1.0);
  const double v_exact = 4.0 / 3 * pi * r * r * r, a_exact = 4 * pi * r * r;
  double prev_ev = 1, prev_ea = 1;
  for (int across : {10, 20}) {
    const SdfGrid g = sphere_grid(r, Vec3(0.02, -0.01, 0.005), 2 * r / across);
    const GridTotals t = integrate_grid(g, 4);
    const double ev = std::abs(t.volume / v_exact - 1), ea = std::abs(t.area / a_exact - 1);
    std::printf("  sphere %2d cells across: volume error %.3e, area error %.3e (relative)\n",
                across, ev, ea);
    EXPECT_LT(ev, 0.03);
    EXPECT_LT(ea, 0.03);
    EXPECT_LT(ev, prev_ev);
    EXPECT_LT(ea, prev_ea);
    prev_ev = ev / 2, prev_ea = ea / 2;  // refinement must gain at least a factor 2
  }
}

// --- marching tetrahedra --------------------------------------------------------------------

TEST(SurfaceExtraction, SphereIsWatertightOutwardAndAccurate) {
  const double r = 0.3, pi = std::acos(-1.0);
  const SdfGrid g = sphere_grid(r, Vec3(0.02, -0.01, 0.005), 2 * r / 16);
  const SurfaceMesh mesh = extract_surface(g, sign_change_cells(g));
  const std::vector<Vec3> x = surface_positions(mesh, g, nullptr);
  ASSERT_GT(mesh.triangles.size(), 100u);

  std::map<std::pair<int, int>, int> directed;
  double area = 0, signed_volume = 0;
  for (const auto& t : mesh.triangles) {
    for (int e = 0; e < 3; ++e) ++directed[{t[e], t[(e + 1) % 3]}];
    area += 0.5 * (x[t[1]] - x[t[0]]).cross(x[t[2]] - x[t[0]]).norm();
    signed_volume += x[t[0]].dot(x[t[1]].cross(x[t[2]])) / 6;
  }
  // Closed and consistently oriented: each directed edge once, its reverse exactly once.
  for (const auto& [edge, count] : directed) {
    ASSERT_EQ(count, 1) << edge.first << "-" << edge.second;
    ASSERT_EQ(directed.count({edge.second, edge.first}), 1u) << edge.first << "-" << edge.second;
  }
  const double v_exact = 4.0 / 3 * pi * r * r * r, a_exact = 4 * pi * r * r;
  std::printf("  marching tets, 16 cells across: %zu triangles, volume error %.3e, area "
              "error %.3e\n", mesh.triangles.size(), signed_volume / v_exact - 1, area / a_exact - 1);
  EXPECT_NEAR(signed_volume / v_exact, 1.0, 0.03);
  EXPECT_NEAR(area / a_exact, 1.0, 0.03);

  // Same tetrahedra as integrate_cut_cell with one subdivision: identical area.
  double integrated_area = 0;
  for (long base : sign_change_cells(g)) {
    const int i = int(base % g.size.x()), j = int(base / g.size.x() % g.size.y()),
              k = int(base / (long(g.size.x()) * g.size.y()));
    integrated_area += integrate_cut_cell(cell_phi(g, i, j, k), g.cell_size, 1).area_total;
  }
  EXPECT_NEAR(area, integrated_area, 1e-12 * a_exact);
}

TEST(SurfaceExtraction, VerticesLieOnZeroCrossingsOfGridEdges) {
  const SdfGrid g = sphere_grid(0.3, Vec3(0, 0, 0), 0.075);
  const SurfaceMesh mesh = extract_surface(g, sign_change_cells(g));
  const long nx = g.size.x(), ny = g.size.y();
  std::map<std::pair<long, long>, int> seen;
  for (const SurfaceVertex& v : mesh.vertices) {
    ASSERT_LT(v.node_a, v.node_b);
    ASSERT_GE(v.t, 0.0);
    ASSERT_LE(v.t, 1.0);
    EXPECT_EQ(seen[std::make_pair(v.node_a, v.node_b)]++, 0) << "vertex not shared per edge";
    // Tetrahedron edges join cell corners whose bits include each other: node_b is node_a
    // plus a non-empty subset of the unit steps in x, y and z.
    const long d = v.node_b - v.node_a;
    bool subset_step = false;
    for (int bits = 1; bits < 8; ++bits)
      subset_step |= d == (bits & 1) + nx * (((bits >> 1) & 1) + ny * ((bits >> 2) & 1));
    EXPECT_TRUE(subset_step) << d;
    const double f = (1 - v.t) * g.phi[v.node_a] + v.t * g.phi[v.node_b];
    EXPECT_NEAR(f, 0.0, 1e-15);
  }
}

TEST(SurfaceExtraction, DisplacedPositionsLerpDisplacedNodes) {
  const SdfGrid g = sphere_grid(0.3, Vec3(0, 0, 0), 0.1);
  const SurfaceMesh mesh = extract_surface(g, sign_change_cells(g));
  const std::vector<Vec3> rest = surface_positions(mesh, g, nullptr);
  // Affine node displacement u(x) = A x + b: lerped vertices move by exactly u(vertex).
  Eigen::Matrix3d a;
  a << 0.1, 0.02, 0, -0.03, 0.05, 0.01, 0, 0.04, -0.02;
  const Vec3 b(0.5, -0.25, 1.0);
  std::vector<double> u(3 * g.node_count());
  for (int k = 0; k < g.size.z(); ++k)
    for (int j = 0; j < g.size.y(); ++j)
      for (int i = 0; i < g.size.x(); ++i) {
        Eigen::Map<Vec3> node_u(&u[3 * g.index(i, j, k)]);
        node_u = a * g.node_position(i, j, k) + b;
      }
  const std::vector<Vec3> moved = surface_positions(mesh, g, u.data());
  ASSERT_EQ(moved.size(), rest.size());
  for (size_t v = 0; v < rest.size(); ++v)
    EXPECT_LT((moved[v] - (rest[v] + a * rest[v] + b)).norm(), 1e-12);
}

TEST(SurfaceExtraction, ZeroFaceBetweenFullAndEmptyCellsStaysClosed) {
  // A box whose faces lie exactly on grid nodes (phi == 0 there, as zero-cutoff snapping
  // produces): zero-area triangles are kept, so the mesh stays closed and oriented.
  SdfGrid g;
  g.cell_size = 1;
  g.size = Eigen::Vector3i(6, 6, 6);
  g.phi.resize(g.node_count());
  for (int k = 0; k < 6; ++k)
    for (int j = 0; j < 6; ++j)
      for (int i = 0; i < 6; ++i)
        g.phi[g.index(i, j, k)] = std::max({std::abs(i - 2.5), std::abs(j - 2.5), std::abs(k - 2.5)}) - 1.5;
  std::vector<long> all;
  for (int k = 0; k < 5; ++k)
    for (int j = 0; j < 5; ++j)
      for (int i = 0; i < 5; ++i) all.push_back(g.index(i, j, k));
  const SurfaceMesh mesh = extract_surface(g, all);
  const std::vector<Vec3> x = surface_positions(mesh, g, nullptr);
  std::map<std::pair<int, int>, int> directed;
  double area = 0, signed_volume = 0;
  for (const auto& t : mesh.triangles) {
    for (int e = 0; e < 3; ++e) ++directed[{t[e], t[(e + 1) % 3]}];
    area += 0.5 * (x[t[1]] - x[t[0]]).cross(x[t[2]] - x[t[0]]).norm();
    signed_volume += x[t[0]].dot(x[t[1]].cross(x[t[2]])) / 6;
  }
  for (const auto& [edge, count] : directed) {
    ASSERT_EQ(count, 1);
    ASSERT_EQ(directed.count({edge.second, edge.first}), 1u);
  }
  EXPECT_NEAR(area, 6 * 9.0, 1e-12);
  EXPECT_NEAR(signed_volume, 27.0, 1e-12);
  // The integrator reports the same faces once, from the cells outside the box.
  double integrated_area = 0, integrated_volume = 0;
  for (int k = 0; k < 5; ++k)
    for (int j = 0; j < 5; ++j)
      for (int i = 0; i < 5; ++i) {
        const CutCellIntegrals r = integrate_cut_cell(cell_phi(g, i, j, k), 1.0);
        integrated_area += r.area_total;
        integrated_volume += r.volume_total;
      }
  EXPECT_NEAR(integrated_area, 54.0, 1e-12);
  EXPECT_NEAR(integrated_volume, 27.0, 1e-12);
}

TEST(SurfaceExtraction, RejectsCellsOutsideTheGrid) {
  const SdfGrid g = sphere_grid(0.3, Vec3(0, 0, 0), 0.1);
  EXPECT_THROW(extract_surface(g, {g.index(g.size.x() - 1, 0, 0)}), InputError);
  EXPECT_THROW(extract_surface(g, {g.index(0, 0, g.size.z() - 1)}), InputError);
  EXPECT_THROW(extract_surface(g, {-1}), InputError);
  EXPECT_TRUE(extract_surface(g, {g.index(0, 0, 0)}).triangles.empty());  // far outside
}

// --- PLY ------------------------------------------------------------------------------------

std::string temp_dir() {
  const auto dir = std::filesystem::temp_directory_path() /
                   ("ssc_cut_cell_test_" + std::to_string(long(::getpid())));
  std::filesystem::create_directories(dir);
  return dir.string();
}

std::uint32_t read_u32(const std::string& s, size_t at) {
  std::uint32_t v = 0;
  for (int b = 0; b < 4; ++b) v |= std::uint32_t(static_cast<unsigned char>(s[at + b])) << (8 * b);
  return v;
}

float read_float(const std::string& s, size_t at) {
  const std::uint32_t bits = read_u32(s, at);
  float f;
  std::memcpy(&f, &bits, sizeof f);
  return f;
}

TEST(SurfacePly, WritesBinaryLittleEndianAndReadsBack) {
  const SdfGrid g = sphere_grid(0.3, Vec3(0, 0, 0), 0.1);
  const SurfaceMesh mesh = extract_surface(g, sign_change_cells(g));
  const std::vector<Vec3> x = surface_positions(mesh, g, nullptr);
  const std::string path = temp_dir() + "/sphere.ply";
  write_ply(path, x, mesh.triangles);

  std::ifstream in(path, std::ios::binary);
  const std::string data((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const std::string end = "end_header\n";
  const size_t body = data.find(end) + end.size();
  ASSERT_NE(data.find(end), std::string::npos);
  std::istringstream header(data.substr(0, body));
  std::string line;
  std::vector<std::string> lines;
  while (std::getline(header, line)) lines.push_back(line);
  ASSERT_GE(lines.size(), 3u);
  EXPECT_EQ(lines[0], "ply");
  EXPECT_EQ(lines[1], "format binary_little_endian 1.0");
  long nv = -1, nf = -1;
  for (const std::string& l : lines) {
    std::sscanf(l.c_str(), "element vertex %ld", &nv);
    std::sscanf(l.c_str(), "element face %ld", &nf);
  }
  EXPECT_NE(data.find("property list uchar int vertex_indices\n"), std::string::npos);
  ASSERT_EQ(nv, long(x.size()));
  ASSERT_EQ(nf, long(mesh.triangles.size()));
  ASSERT_EQ(data.size(), body + 12 * x.size() + 13 * mesh.triangles.size());
  for (size_t v = 0; v < x.size(); ++v)
    for (int a = 0; a < 3; ++a) EXPECT_EQ(read_float(data, body + 12 * v + 4 * a), float(x[v][a]));
  const size_t faces = body + 12 * x.size();
  for (size_t f = 0; f < mesh.triangles.size(); ++f) {
    ASSERT_EQ(data[faces + 13 * f], char(3));
    for (int e = 0; e < 3; ++e)
      EXPECT_EQ(int(read_u32(data, faces + 13 * f + 1 + 4 * e)), mesh.triangles[f][e]);
  }
  // No temporary left behind.
  for (const auto& entry : std::filesystem::directory_iterator(temp_dir()))
    EXPECT_EQ(entry.path().filename().string().find(".tmp-"), std::string::npos);
  std::filesystem::remove_all(temp_dir());
}

TEST(SurfacePly, FailureNamesThePathAndLeavesNoTemporary) {
  const std::string missing = temp_dir() + "/no/such/dir/out.ply";
  try {
    write_ply(missing, {Vec3(0, 0, 0)}, {});
    FAIL() << "expected std::runtime_error";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find(missing), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("No such file"), std::string::npos) << e.what();
  }
  // Renaming onto an existing directory fails after the temporary was written.
  const std::string dir_target = temp_dir() + "/is_a_dir";
  std::filesystem::create_directories(dir_target + "/child");
  EXPECT_THROW(write_ply(dir_target, {Vec3(0, 0, 0)}, {}), std::runtime_error);
  for (const auto& entry : std::filesystem::directory_iterator(temp_dir()))
    EXPECT_EQ(entry.path().filename().string().find(".tmp-"), std::string::npos);
  EXPECT_THROW(write_ply(temp_dir() + "/bad.ply", {Vec3(0, 0, 0)}, {{0, 1, 0}}),
               std::invalid_argument);
  EXPECT_FALSE(std::filesystem::exists(temp_dir() + "/bad.ply"));
  std::filesystem::remove_all(temp_dir());
}

}  // namespace
}  // namespace ssc
