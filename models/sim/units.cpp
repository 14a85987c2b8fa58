// Unit conversion of scene parameters (see units.h).
#include "models/sim/units.h"

#include <fmt/format.h>

#include <cmath>

#include "models/io/json_reader.h"
#include "models/sim/parameter_table.h"

namespace ssc {

UnitScales unit_scales(const Scene& scene, const SimGrid& grid) {
  UnitScales u;
  if (!scene.extra.contains("units")) return u;
  const JsonReader r(scene.extra.at("units"), scene.file, "units");
  u.time = r.positive("time", r.number("time", 1.0));
  if (r.has("object_size") || r.has("object_mass")) {
    r.require(!r.has("length") && !r.has("mass"), "length", "and mass cannot be combined with object_size/object_mass");
    // The body's extent from its surface points.
    Eigen::Vector3d lo = Eigen::Vector3d::Constant(1e300), hi = -lo;
    for (const ContactPoint& p : grid.contact_points)
      for (int k = 0; k < 3; ++k) {
        const double x = p.at(grid.node_rest, k);
        lo[k] = std::min(lo[k], x);
        hi[k] = std::max(hi[k], x);
      }
    const double extent = std::max((hi - lo).maxCoeff(), grid.h);
    u.length = r.positive("object_size", r.number("object_size")) / extent;
    u.mass = r.positive("object_mass", r.number("object_mass")) / (scene.material.density * grid.total_volume);
  } else {
    u.length = r.positive("length", r.number("length", 1.0));
    u.mass = r.positive("mass", r.number("mass", 1.0));
  }
  r.reject_unknown_keys();
  return u;
}

double to_si(const std::string& name, double v, const UnitScales& u) {
  const ParameterRow row = parameter_row(name);
  return v * std::pow(u.mass, row.mass) * std::pow(u.length, row.length) * std::pow(u.time, row.time);
}

}  // namespace ssc
