// Marching tetrahedra over listed grid cells (see marching_tets.h).
//
// Orientation rule, for a positively oriented tetrahedron (v0,v1,v2,v3) and P an even
// permutation of its vertices:
//   one vertex P0 inside:      triangle (e(P0,P1), e(P0,P2), e(P0,P3)) faces away from P0;
//   one vertex P0 outside:     the reverse (e(P0,P1), e(P0,P3), e(P0,P2)) faces towards P0;
//   P0,P1 inside, P2,P3 out:   quad (e(P0,P2), e(P0,P3), e(P1,P3), e(P1,P2)) faces outward.
// (Check on v0 = 0, v1 = e_x, v2 = e_y, v3 = e_z: the face (v1,v2,v3) has normal (1,1,1).)
#include "models/grid/marching_tets.h"

#include "models/grid/cut_cell.h"
#include "runtime/errors.h"

#include <cmath>
#include <string>
#include <unordered_map>
#include <utility>

namespace ssc {
namespace {

struct EdgeKey {
  long a, b;
  bool operator==(const EdgeKey& o) const { return a == o.a && b == o.b; }
};

struct EdgeKeyHash {
  size_t operator()(const EdgeKey& k) const {
    const auto x = static_cast<unsigned long long>(k.a) * 0x9E3779B97F4A7C15ull;
    return static_cast<size_t>(x ^ (static_cast<unsigned long long>(k.b) + (x >> 29)));
  }
};

// Builds the mesh, sharing one vertex per (node_a, node_b) edge.
class SurfaceBuilder {
 public:
  explicit SurfaceBuilder(const SdfGrid& sdf) : sdf_(sdf) {}

  void add_cell(long base) {
    long node[8];
    double phi[8];
    corner_nodes(base, node, phi);
    for (const auto& tet : kCellTetrahedra) {
      long n[4];
      double f[4];
      for (int v = 0; v < 4; ++v) n[v] = node[tet[v]], f[v] = phi[tet[v]];
      add_tet(n, f);
    }
  }

  SurfaceMesh take() { return std::move(mesh_); }

 private:
  void corner_nodes(long base, long node[8], double phi[8]) const {
    const long nx = sdf_.size.x(), ny = sdf_.size.y(), nz = sdf_.size.z();
    const long i = base % nx, j = (base / nx) % ny, k = base / (nx * ny);
    if (base < 0 || i >= nx - 1 || j >= ny - 1 || k >= nz - 1)
      throw InputError("extract_surface: cell with lower corner node " + std::to_string(base) +
                       " is not inside the SDF grid; a cell needs a node layer above it");
    for (int c = 0; c < 8; ++c) {
      node[c] = base + (c & 1) + nx * (((c >> 1) & 1) + ny * ((c >> 2) & 1));
      phi[c] = sdf_.phi[node[c]];
      if (!std::isfinite(phi[c]))
        throw InputError("extract_surface: non-finite SDF value at node " +
                         std::to_string(node[c]) + "; check the SDF grid for NaN/Inf");
    }
  }

  // Vertex on the edge between node p and node q (one inside, one outside).
  int vertex(long p, double fp, long q, double fq) {
    if (p > q) std::swap(p, q), std::swap(fp, fq);
    const auto [it, added] = index_.try_emplace(EdgeKey{p, q}, int(mesh_.vertices.size()));
    if (added) mesh_.vertices.push_back({p, q, fp / (fp - fq)});
    return it->second;
  }

  void add_tet(const long n[4], const double f[4]) {
    int in[4], out[4], n_in = 0, n_out = 0;
    for (int v = 0; v < 4; ++v) (f[v] <= 0 ? in[n_in++] : out[n_out++]) = v;
    auto e = [&](int u, int v) { return vertex(n[u], f[u], n[v], f[v]); };
    if (n_in == 1 || n_in == 3) {
      const int lone = (n_in == 1) ? in[0] : out[0];
      const std::array<int, 4> p = even_permutation_starting_with(lone, -1);
      if (n_in == 1)
        mesh_.triangles.push_back({e(p[0], p[1]), e(p[0], p[2]), e(p[0], p[3])});
      else
        mesh_.triangles.push_back({e(p[0], p[1]), e(p[0], p[3]), e(p[0], p[2])});
    } else if (n_in == 2) {
      const std::array<int, 4> p = even_permutation_starting_with(in[0], in[1]);
      const int q0 = e(p[0], p[2]), q1 = e(p[0], p[3]), q2 = e(p[1], p[3]), q3 = e(p[1], p[2]);
      mesh_.triangles.push_back({q0, q1, q2});
      mesh_.triangles.push_back({q0, q2, q3});
    }
  }

  // An even permutation of (0,1,2,3) that starts with first (and then second, if >= 0).
  static std::array<int, 4> even_permutation_starting_with(int first, int second) {
    std::array<int, 4> p{first, 0, 0, 0};
    int m = 1;
    if (second >= 0) p[m++] = second;
    for (int v = 0; v < 4; ++v)
      if (v != first && v != second) p[m++] = v;
    int inversions = 0;
    for (int a = 0; a < 4; ++a)
      for (int b = a + 1; b < 4; ++b) inversions += p[a] > p[b];
    if (inversions % 2) std::swap(p[2], p[3]);
    return p;
  }

  const SdfGrid& sdf_;
  SurfaceMesh mesh_;
  std::unordered_map<EdgeKey, int, EdgeKeyHash> index_;
};

}  // namespace

SurfaceMesh extract_surface(const SdfGrid& sdf, const std::vector<long>& cells) {
  if (long(sdf.phi.size()) != sdf.node_count())
    throw InputError("extract_surface: SDF grid has " + std::to_string(sdf.phi.size()) +
                     " values for " + std::to_string(sdf.node_count()) + " nodes");
  SurfaceBuilder builder(sdf);
  for (long base : cells) builder.add_cell(base);
  return builder.take();
}

std::vector<Eigen::Vector3d> surface_positions(const SurfaceMesh& mesh, const SdfGrid& rest,
                                               const double* node_displacement) {
  const long nx = rest.size.x(), ny = rest.size.y(), count = rest.node_count();
  auto position = [&](long node) {
    if (node < 0 || node >= count)
      throw InputError("surface_positions: vertex node " + std::to_string(node) +
                       " is outside the grid of " + std::to_string(count) + " nodes");
    Eigen::Vector3d x = rest.node_position(int(node % nx), int((node / nx) % ny),
                                           int(node / (nx * ny)));
    if (node_displacement) x += Eigen::Map<const Eigen::Vector3d>(node_displacement + 3 * node);
    return x;
  };
  std::vector<Eigen::Vector3d> out;
  out.reserve(mesh.vertices.size());
  for (const SurfaceVertex& v : mesh.vertices)
    out.push_back((1 - v.t) * position(v.node_a) + v.t * position(v.node_b));
  return out;
}

}  // namespace ssc
