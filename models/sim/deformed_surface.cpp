// Deformed surface meshes of a simulated body (see deformed_surface.h).
#include "models/sim/deformed_surface.h"

#include <unordered_map>

namespace ssc {

DeformedSurface::DeformedSurface(const SimGrid& grid, int refinement) : grid_(grid) {
  const SdfGrid& coarse = grid.sdf;
  const int s = std::max(1, refinement);
  SdfGrid fine;
  fine.cell_size = coarse.cell_size / s;
  fine.origin = coarse.origin;
  fine.size = (coarse.size.array() - 1) * s + 1;
  fine.phi.assign(fine.node_count(), 1.0);
  std::unordered_map<long, RefinedNode> location;
  std::vector<long> fine_cells;
  const long cnx = coarse.size.x(), cnxy = cnx * coarse.size.y();
  for (int e = 0; e < grid.cell_count; ++e) {
    const long o = grid.cell_origin[e];
    const int ci = int(o % cnx), cj = int((o / cnx) % coarse.size.y()), ck = int(o / cnxy);
    double phi[8];
    for (int q = 0; q < 8; ++q) phi[q] = coarse.phi[o + (q & 1) + ((q >> 1) & 1) * cnx + ((q >> 2) & 1) * cnxy];
    for (int z = 0; z <= s; ++z)
      for (int y = 0; y <= s; ++y)
        for (int x = 0; x <= s; ++x) {
          const double a = double(x) / s, b = double(y) / s, c = double(z) / s;
          double v = 0;
          for (int q = 0; q < 8; ++q)
            v += phi[q] * ((q & 1) ? a : 1 - a) * ((q & 2) ? b : 1 - b) * ((q & 4) ? c : 1 - c);
          const long n = fine.index(ci * s + x, cj * s + y, ck * s + z);
          // A face on a grid plane (phi = 0 at its nodes, > 0 beyond) bounds no simulated cell
          // from inside: moved 1e-6 cells inwards it is extracted from the body's cells.
          fine.phi[n] = v + 1e-6 * coarse.cell_size;
          location.emplace(n, RefinedNode{e, a, b, c});
          if (x < s && y < s && z < s) fine_cells.push_back(n);
        }
  }
  mesh_ = extract_surface(fine, fine_cells);
  std::unordered_map<long, int> used_index;
  auto use = [&](long n) {
    auto it = used_index.find(n);
    if (it != used_index.end()) return it->second;
    const int id = int(used_nodes_.size());
    used_index.emplace(n, id);
    used_nodes_.push_back(n);
    used_location_.push_back(location.at(n));
    return id;
  };
  for (const SurfaceVertex& v : mesh_.vertices) vertex_nodes_.push_back({use(v.node_a), use(v.node_b)});
}

std::vector<Eigen::Vector3d> DeformedSurface::positions(const double* u) const {
  std::vector<Eigen::Vector3d> node_pos(used_nodes_.size());
  for (size_t k = 0; k < used_nodes_.size(); ++k) {
    const RefinedNode& r = used_location_[k];
    Eigen::Vector3d p = Eigen::Vector3d::Zero();
    for (int q = 0; q < 8; ++q) {
      const double w = ((q & 1) ? r.a : 1 - r.a) * ((q & 2) ? r.b : 1 - r.b) * ((q & 4) ? r.c : 1 - r.c);
      const int n = grid_.cell_nodes[8 * r.cell + q];
      p += w * Eigen::Vector3d(grid_.node_rest[3 * n] + u[3 * n], grid_.node_rest[3 * n + 1] + u[3 * n + 1],
                               grid_.node_rest[3 * n + 2] + u[3 * n + 2]);
    }
    node_pos[k] = p;
  }
  std::vector<Eigen::Vector3d> out(mesh_.vertices.size());
  for (size_t i = 0; i < mesh_.vertices.size(); ++i) {
    const double t = mesh_.vertices[i].t;
    out[i] = (1 - t) * node_pos[vertex_nodes_[i][0]] + t * node_pos[vertex_nodes_[i][1]];
  }
  return out;
}

}  // namespace ssc
