// The static arrays by name (see static_arrays.h).
#include "runtime/static_arrays.h"

#include "ops/contact.h"

namespace ssc {

static_assert(kPointNodes == ops::kPointNodes, "the ops read contact points as the grid lays them out");

std::vector<NamedStaticArray> named_static_arrays(const StaticArrays& g) {
  std::vector<NamedStaticArray> a;
  auto ints = [&](const char* name, std::vector<int> v) { a.push_back({name, true, std::move(v), {}}); };
  auto reals = [&](const char* name, std::vector<double> v) { a.push_back({name, false, {}, std::move(v)}); };
  ints("cell_nodes", g.cell_nodes);
  reals("cell_weights", g.cell_volume_weights);
  reals("cell_offset", g.cell_offset);
  reals("cell_surface_weights", g.cell_surface_weights);
  reals("cell_rest_normal", g.cell_rest_normal);
  reals("cell_region_share", g.cell_region_share);
  ints("region_count", g.region_count);
  reals("node_volume", g.node_volume);
  reals("node_rest", g.node_rest);
  ints("node_cell_offset", g.node_cell_offset);
  ints("node_cell_entry", g.node_cell_entry);
  std::vector<int> pn;
  std::vector<double> pw, pa;
  for (const ContactPoint& p : g.contact_points) {
    pn.insert(pn.end(), p.nodes, p.nodes + kPointNodes);
    pw.insert(pw.end(), p.weights, p.weights + kPointNodes);
    pa.push_back(p.area);
  }
  ints("point_nodes", pn);
  reals("point_weights", pw);
  reals("point_area", pa);
  ints("node_point_offset", g.node_point_offset);
  ints("node_point_entry", g.node_point_entry);
  ints("band_neighbors", g.band_neighbors);
  ints("band_degree", g.band_degree);
  std::vector<std::vector<int>> nb(g.node_count);
  for (int i = 0; i < g.band_count; ++i)
    for (int k = 0; k < 6; ++k)
      if (g.band_neighbors[6 * i + k] <= -2) nb[-g.band_neighbors[6 * i + k] - 2].push_back(i);
  std::vector<int> off{0}, ent;
  for (const auto& l : nb) {
    ent.insert(ent.end(), l.begin(), l.end());
    off.push_back(int(ent.size()));
  }
  ints("node_band_offset", off);
  ints("node_band_entry", ent);
  return a;
}

}  // namespace ssc
