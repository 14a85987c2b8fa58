// Construction of the simulation grid from a rest SDF (see sim_grid.h for the rules).
#include "models/grid/sim_grid.h"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <deque>
#include <map>

#include "models/grid/cut_cell.h"
#include "ops/trilinear.h"
#include "runtime/errors.h"

namespace ssc {
namespace {

void apply_zero_cutoff(SdfGrid& sdf, double zero_cutoff) {
  const double limit = zero_cutoff * sdf.cell_size;
  for (double& v : sdf.phi)
    if (std::abs(v) < limit) v = 0.0;
}

std::array<long, 8> corner_indices(const SdfGrid& sdf, long origin) {
  const long nx = sdf.size.x(), nxy = nx * sdf.size.y();
  std::array<long, 8> idx;
  for (int c = 0; c < 8; ++c) idx[c] = origin + (c & 1) + ((c >> 1) & 1) * nx + ((c >> 2) & 1) * nxy;
  return idx;
}

void find_active_cells(SimGrid& g) {
  const SdfGrid& s = g.sdf;
  g.cell_at_origin.assign(s.node_count(), -1);
  std::vector<char> active_node(s.node_count(), 0);
  for (int k = 0; k + 1 < s.size.z(); ++k)
    for (int j = 0; j + 1 < s.size.y(); ++j)
      for (int i = 0; i + 1 < s.size.x(); ++i) {
        const long o = s.index(i, j, k);
        const auto idx = corner_indices(s, o);
        bool inside = false;
        for (long n : idx) inside |= s.phi[n] < 0.0;
        if (!inside) continue;
        g.cell_at_origin[o] = int(g.cell_origin.size());
        g.cell_origin.push_back(o);
        for (long n : idx) active_node[n] = 1;
      }
  g.cell_count = int(g.cell_origin.size());
  g.grid_kind.assign(s.node_count(), -1);
  for (long n = 0; n < s.node_count(); ++n)
    if (active_node[n]) {
      g.grid_kind[n] = int(g.node_grid.size());
      g.node_grid.push_back(n);
    }
  g.node_count = int(g.node_grid.size());
  g.node_rest.resize(3 * size_t(g.node_count));
  for (int a = 0; a < g.node_count; ++a) {
    const long n = g.node_grid[a];
    const int i = int(n % s.size.x()), j = int((n / s.size.x()) % s.size.y()), k = int(n / (long(s.size.x()) * s.size.y()));
    const Eigen::Vector3d x = s.node_position(i, j, k);
    for (int d = 0; d < 3; ++d) g.node_rest[3 * a + d] = x[d];
  }
  g.cell_nodes.resize(8 * size_t(g.cell_count));
  for (int e = 0; e < g.cell_count; ++e) {
    const auto idx = corner_indices(s, g.cell_origin[e]);
    for (int c = 0; c < 8; ++c) g.cell_nodes[8 * e + c] = g.grid_kind[idx[c]];
  }
}

// Every corner weight is raised to a floor (a fraction of a full cell's h^3/8), so that a
// node touched by the body only at a point still has a little mass and stiffness and
// moves with its neighbours instead of falling freely (see docs/validation.md).
void integrate_cells(SimGrid& g, const GridOptions& opt) {
  const double floor = opt.min_node_volume * g.h * g.h * g.h / 8.0;
  g.cell_volume_weights.resize(8 * size_t(g.cell_count));
  g.cell_surface_weights.resize(8 * size_t(g.cell_count));
  g.cell_rest_normal.assign(3 * size_t(g.cell_count), 0.0);
  g.cell_volume.resize(g.cell_count);
  g.cell_area.resize(g.cell_count);
  int floored = 0;
#pragma omp parallel for schedule(dynamic, 64) reduction(+ : floored)
  for (int e = 0; e < g.cell_count; ++e) {
    const auto idx = corner_indices(g.sdf, g.cell_origin[e]);
    std::array<double, 8> phi;
    for (int c = 0; c < 8; ++c) phi[c] = g.sdf.phi[idx[c]];
    const CutCellIntegrals r = integrate_cut_cell(phi, g.h, opt.integration_subdivisions);
    // A surface on a cell face (phi = 0 at its corners: faces on grid planes) is counted by
    // the empty cell beyond it, which is not simulated; the surface weights and the area (the
    // contact points' shares, the drag) take it inside (phi + 1e-6 h).
    bool on_face = false;
    std::array<double, 8> shifted;
    for (int c = 0; c < 8; ++c) {
      on_face = on_face || phi[c] == 0;
      shifted[c] = phi[c] + 1e-6 * g.h;
    }
    const CutCellIntegrals s = on_face ? integrate_cut_cell(shifted, g.h, opt.integration_subdivisions) : r;
    for (int c = 0; c < 8; ++c) {
      g.cell_volume_weights[8 * e + c] = std::max(r.volume[c], floor);
      g.cell_surface_weights[8 * e + c] = s.surface[c];
    }
    if (s.area_total > 0) {  // the trilinear phi's gradient at the cell centre
      Eigen::Vector3d n = Eigen::Vector3d::Zero();
      for (int c = 0; c < 8; ++c)
        for (int a = 0; a < 3; ++a) n[a] += ((c >> a) & 1 ? phi[c] : -phi[c]) / (4 * g.h);
      if (n.norm() > 0) n.normalize();
      for (int a = 0; a < 3; ++a) g.cell_rest_normal[3 * size_t(e) + a] = n[a];
    }
    for (int c = 0; c < 8; ++c) floored += r.volume[c] < floor;
    g.cell_volume[e] = r.volume_total;
    g.cell_area[e] = s.area_total;
  }
  g.floored_weights = floored;
}

void build_node_cell_incidence(SimGrid& g) {
  std::vector<int> count(g.node_count, 0);
  for (int n : g.cell_nodes) ++count[n];
  g.node_cell_offset.assign(g.node_count + 1, 0);
  for (int a = 0; a < g.node_count; ++a) g.node_cell_offset[a + 1] = g.node_cell_offset[a] + count[a];
  g.node_cell_entry.resize(g.node_cell_offset.back());
  std::vector<int> fill(g.node_cell_offset.begin(), g.node_cell_offset.end() - 1);
  for (int e = 0; e < g.cell_count; ++e)
    for (int c = 0; c < 8; ++c) g.node_cell_entry[fill[g.cell_nodes[8 * e + c]]++] = 8 * e + c;

  g.node_volume.assign(g.node_count, 0.0);
  g.total_volume = 0;
  Eigen::Vector3d moment = Eigen::Vector3d::Zero();
  for (int a = 0; a < g.node_count; ++a) {
    double v = 0;
    for (int k = g.node_cell_offset[a]; k < g.node_cell_offset[a + 1]; ++k) v += g.cell_volume_weights[g.node_cell_entry[k]];
    moment += v * Eigen::Vector3d(g.node_rest[3 * a], g.node_rest[3 * a + 1], g.node_rest[3 * a + 2]);
    g.node_volume[a] = v;
  }
  for (double v : g.cell_volume) g.total_volume += v;
  double lumped = 0;
  for (double v : g.node_volume) lumped += v;
  g.rest_center_of_mass = moment / lumped;

  // Each cell's rest centroid of its inside part: sum_c w_c x_c / sum_c w_c (the trilinear
  // shape functions reproduce x, so this is the centroid of the weighted part).
  g.cell_center.assign(3 * size_t(g.cell_count), 0.0);
  g.cell_offset.assign(3 * size_t(g.cell_count), 0.0);
  for (int e = 0; e < g.cell_count; ++e) {
    Eigen::Vector3d x = Eigen::Vector3d::Zero();
    double w = 0;
    for (int c = 0; c < 8; ++c) {
      const int n = g.cell_nodes[8 * e + c];
      const double wc = g.cell_volume_weights[8 * e + c];
      x += wc * Eigen::Vector3d(g.node_rest[3 * n], g.node_rest[3 * n + 1], g.node_rest[3 * n + 2]);
      w += wc;
    }
    x /= w;
    for (int k = 0; k < 3; ++k) {
      g.cell_center[3 * e + k] = x[k];
      g.cell_offset[3 * e + k] = x[k] - g.rest_center_of_mass[k];
    }
  }
  g.cell_region_share.clear();
  g.region_count = {0};
}

// Contact points (sim_grid.h): each active cell is split into s^3 sub-cells; a point sits where
// the rest surface crosses a sub-cell edge (phi < 0 at one end, > 0 at the other) and at every
// lattice node on the surface (|phi| under the zero cutoff). With s = 1 and the grid's own
// values these are the paper's edge crossings plus the surface nodes: a box whose faces lie on
// grid planes has its surface on nodes, and with crossings alone its rims got no point and a
// soft cube sliding with friction tipped over the row before them. Off the grid planes the
// trilinear zero level bevels every convex edge across a cell, so a box's base has points only
// out to a cell inside its rims, and the cube tips all the same (docs/diagnosis.md); phi is then
// the shape's exact distance, on a lattice of s > 1. Each point carries its cell's trilinear
// weights and an equal share of its cell's cut surface area.
void build_contact_points(SimGrid& g, const RestSurface& exact, int s, double zero_cutoff) {
  const SdfGrid& sdf = g.sdf;
  const long nx = sdf.size.x(), ny = sdf.size.y();
  const long lx = (nx - 1) * s + 1, ly = (ny - 1) * s + 1;
  const double cutoff = zero_cutoff * g.h;
  std::map<std::pair<long, long>, int> point_of;  // lattice node pair of a crossing, (n, n) for a surface node
  std::vector<double> phi(size_t((s + 1) * (s + 1) * (s + 1)));
  for (int e = 0; e < g.cell_count; ++e) {
    const long o = g.cell_origin[e];
    const long ci = o % nx, cj = (o / nx) % ny, ck = o / (nx * ny);
    const auto idx = corner_indices(sdf, o);
    const Eigen::Vector3d corner0 = sdf.node_position(o);
    auto local_index = [&](int a, int b, int c) { return size_t((c * (s + 1) + b) * (s + 1) + a); };
    for (int c = 0; c <= s; ++c)
      for (int b = 0; b <= s; ++b)
        for (int a = 0; a <= s; ++a) {
          const Eigen::Vector3d t(double(a) / s, double(b) / s, double(c) / s);
          double v = 0;
          if (exact) {
            v = exact(corner0 + g.h * t);
          } else {
            double w[8];
            ops::trilinear_weights(make_vec3(t.x(), t.y(), t.z()), w);
            for (int k = 0; k < 8; ++k) v += sdf.phi[idx[k]] * w[k];
          }
          phi[local_index(a, b, c)] = std::abs(v) < cutoff ? 0.0 : v;
        }
    auto lattice_key = [&](const Eigen::Vector3i& q) { return ((ck * s + q.z()) * ly + (cj * s + q.y())) * lx + (ci * s + q.x()); };
    std::vector<int> cell_points;
    auto add = [&](std::pair<long, long> key, const Eigen::Vector3d& t) {
      auto it = point_of.find(key);
      if (it == point_of.end()) {
        it = point_of.emplace(key, int(g.contact_points.size())).first;
        ContactPoint p;
        ops::trilinear_weights(make_vec3(t.x(), t.y(), t.z()), p.weights);
        for (int k = 0; k < kPointNodes; ++k) p.nodes[k] = g.cell_nodes[8 * e + k];
        g.contact_points.push_back(p);
      }
      if (std::find(cell_points.begin(), cell_points.end(), it->second) == cell_points.end())
        cell_points.push_back(it->second);
    };
    for (int c = 0; c <= s; ++c)
      for (int b = 0; b <= s; ++b)
        for (int a = 0; a <= s; ++a) {
          const Eigen::Vector3i q(a, b, c);
          const double pa = phi[local_index(a, b, c)];
          if (pa == 0) add({lattice_key(q), lattice_key(q)}, q.cast<double>() / s);
          for (int d = 0; d < 3; ++d) {
            if (q[d] == s) continue;
            const Eigen::Vector3i r = q + Eigen::Vector3i::Unit(d);
            const double pb = phi[local_index(r.x(), r.y(), r.z())];
            if (pa == 0 || pb == 0 || (pa < 0) == (pb < 0)) continue;
            Eigen::Vector3d t = q.cast<double>();
            t[d] += pa / (pa - pb);
            add({lattice_key(q), lattice_key(r)}, t / s);
          }
        }
    for (int p : cell_points) g.contact_points[p].area += g.cell_area[e] / double(cell_points.size());
  }
  std::vector<int> count(g.node_count, 0);
  for (const auto& p : g.contact_points)
    for (int k = 0; k < kPointNodes; ++k)
      if (p.weights[k] != 0) ++count[p.nodes[k]];
  g.node_point_offset.assign(g.node_count + 1, 0);
  for (int a = 0; a < g.node_count; ++a) g.node_point_offset[a + 1] = g.node_point_offset[a] + count[a];
  g.node_point_entry.resize(g.node_point_offset.back());
  std::vector<int> fill(g.node_point_offset.begin(), g.node_point_offset.end() - 1);
  for (int p = 0; p < int(g.contact_points.size()); ++p)
    for (int k = 0; k < kPointNodes; ++k)
      if (g.contact_points[p].weights[k] != 0) g.node_point_entry[fill[g.contact_points[p].nodes[k]]++] = kPointNodes * p + k;
}

void build_band(SimGrid& g, int band_width) {
  const SdfGrid& s = g.sdf;
  const long total = s.node_count();
  const int unlimited = band_width <= 0;
  std::vector<int> dist(total, -1);
  std::deque<long> queue;
  for (long n : g.node_grid) {
    dist[n] = 0;
    queue.push_back(n);
  }
  const int nx = s.size.x(), ny = s.size.y(), nz = s.size.z();
  auto neighbors = [&](long n, long out[6]) {
    const int i = int(n % nx), j = int((n / nx) % ny), k = int(n / (long(nx) * ny));
    out[0] = i > 0 ? n - 1 : -1;
    out[1] = i + 1 < nx ? n + 1 : -1;
    out[2] = j > 0 ? n - nx : -1;
    out[3] = j + 1 < ny ? n + nx : -1;
    out[4] = k > 0 ? n - long(nx) * ny : -1;
    out[5] = k + 1 < nz ? n + long(nx) * ny : -1;
  };
  while (!queue.empty()) {
    const long n = queue.front();
    queue.pop_front();
    if (!unlimited && dist[n] >= band_width) continue;
    long nb[6];
    neighbors(n, nb);
    for (long m : nb)
      if (m >= 0 && dist[m] < 0) {
        dist[m] = dist[n] + 1;
        queue.push_back(m);
      }
  }
  for (long n = 0; n < total; ++n)
    if (dist[n] > 0) {
      g.grid_kind[n] = -2 - int(g.band_grid.size());  // -(band id) - 2
      g.band_grid.push_back(n);
    }
  g.band_count = int(g.band_grid.size());
  g.band_neighbors.assign(6 * size_t(g.band_count), -1);
  g.band_degree.assign(g.band_count, 0);
  for (int b = 0; b < g.band_count; ++b) {
    long nb[6];
    neighbors(g.band_grid[b], nb);
    for (int d = 0; d < 6; ++d) {
      if (nb[d] < 0) continue;
      const int kind = g.grid_kind[nb[d]];
      if (kind >= 0) {
        g.band_neighbors[6 * b + d] = SimGrid::band_ref_of_active(kind);
      } else if (kind <= -2) {
        g.band_neighbors[6 * b + d] = -kind - 2;
      } else {
        continue;  // beyond the band: a Neumann boundary, like the grid's edge
      }
      ++g.band_degree[b];
    }
  }
}

}  // namespace

SimGrid build_sim_grid(SdfGrid sdf, const GridOptions& options, const std::string& source, const RestSurface& exact) {
  SimGrid g;
  g.h = sdf.cell_size;
  g.sdf = std::move(sdf);
  apply_zero_cutoff(g.sdf, options.zero_cutoff);
  find_active_cells(g);
  if (g.cell_count == 0)
    throw InputError(fmt::format("{}: the object has no grid node with a negative SDF value, so there is "
                                 "nothing to simulate; check the object's size, and lower grid.cell_size (or raise grid.resolution)",
                                 source));
  integrate_cells(g, options);
  build_node_cell_incidence(g);
  build_contact_points(g, exact, exact ? options.contact_subdivisions : 1, options.zero_cutoff);
  build_band(g, options.band_width);
  return g;
}

int find_cell(const SimGrid& grid, const Eigen::Vector3d& rest_point, Eigen::Vector3d* local) {
  const SdfGrid& s = grid.sdf;
  const Eigen::Vector3d q = (rest_point - s.origin) / s.cell_size;
  Eigen::Vector3i ijk;
  for (int d = 0; d < 3; ++d) {
    ijk[d] = int(std::floor(q[d]));
    if (ijk[d] == s.size[d] - 1) --ijk[d];  // a point on the last node plane
    if (ijk[d] < 0 || ijk[d] + 1 >= s.size[d]) return -1;
  }
  const int cell = grid.cell_at_origin[s.index(ijk.x(), ijk.y(), ijk.z())];
  if (cell >= 0 && local) *local = q - ijk.cast<double>();
  return cell;
}

double rest_extent(const SimGrid& grid) {
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(1e300), hi = -lo;
  for (int i = 0; i < grid.node_count; ++i) {
    const Eigen::Vector3d x = grid.sdf.node_position(grid.node_grid[size_t(i)]);
    lo = lo.cwiseMin(x), hi = hi.cwiseMax(x);
  }
  return grid.node_count > 0 ? (hi - lo).maxCoeff() : 1.0;
}

}  // namespace ssc
