#include "models/recording/object_selection.h"

#include <fmt/format.h>

#include "runtime/errors.h"

namespace ssc {

bool size_matches_scan(double part_extent, double scan_extent) {
  return part_extent >= 0.3 * scan_extent && part_extent <= 1.3 * scan_extent;
}

namespace {

std::string describe_parts(const std::vector<DepthComponent>& parts, const std::vector<int>& which) {
  std::string s;
  for (size_t k = 0; k < which.size() && k < 6; ++k) {
    const DepthComponent& p = parts[std::size_t(which[k])];
    s += fmt::format("{}{} pixels around (u, v) = ({:.0f}, {:.0f}), {:.3f} m across{}", k ? "; " : "", p.pixels.size(),
                     p.pixel_centroid.x(), p.pixel_centroid.y(), p.extent, p.touches_border ? " (at the border)" : "");
  }
  if (which.size() > 6) s += fmt::format("; and {} more", which.size() - 6);
  return s;
}

}  // namespace

int select_object_part(const std::vector<DepthComponent>& parts, double scan_extent, double scan_scale,
                       const std::optional<Eigen::Vector2d>& pick, const std::string& where) {
  std::vector<int> all(parts.size());
  for (size_t i = 0; i < parts.size(); ++i) all[i] = int(i);
  if (pick && !parts.empty()) {  // only the part nearest to the picked pixel
    int best = 0;
    double best_d2 = 1e300;
    for (int i : all) {
      const DepthComponent& part = parts[std::size_t(i)];
      const double d2 = (part.pixel_centroid - *pick).squaredNorm();
      if (d2 < best_d2) best_d2 = d2, best = i;
    }
    all = {best};
  }
  std::vector<int> matching;
  for (int i : all)
    if (size_matches_scan(parts[std::size_t(i)].extent, scan_extent)) matching.push_back(i);
  if (matching.empty()) {
    for (int i : all) {
      const double e = parts[std::size_t(i)].extent;
      if (size_matches_scan(e, scan_extent * 1e-3))
        throw InputError(fmt::format(
            "{}: the scan ({:.3g} m across at --scan-scale {}) is about 1000 times the object the camera sees ({:.3f} m "
            "across); the scan is in millimetres: give --scan-scale {}", where, scan_extent, scan_scale, e,
            scan_scale * 0.001));
      if (size_matches_scan(e, scan_extent * 1e3))
        throw InputError(fmt::format(
            "{}: the scan ({:.3g} m across at --scan-scale {}) is about 1000 times smaller than the object the camera "
            "sees ({:.3f} m across); give --scan-scale {}, or check --depth-scale (metres per PNG unit)", where,
            scan_extent, scan_scale, e, scan_scale * 1000));
    }
    if (parts.empty())
      throw InputError(fmt::format("{}: no object found in the first frame: nothing is left once the planes, the static "
                                   "background and the depth edges are removed; check that the object is in view in "
                                   "the first frame (--frames A:B starts later)", where));
    throw InputError(fmt::format("{}: no object found in the first frame whose size matches the scan ({:.3f} m across; "
                                 "a part seen from one side spans 0.3 to 1.3 times that). The parts left once the "
                                 "planes and the static background are removed: {}. Check --scan-scale (metres per "
                                 "scan unit) and --depth-scale, or give --pick u,v", where, scan_extent,
                                 describe_parts(parts, all)));
  }
  if (matching.size() > 1) {
    std::vector<int> inside;
    for (int i : matching)
      if (!parts[std::size_t(i)].touches_border) inside.push_back(i);
    if (inside.size() == 1) return inside[0];
    throw InputError(fmt::format("{}: several candidates for the object in the first frame match the scan's size "
                                 "({:.3f} m across): {}; give --pick u,v, a pixel of the object in the first frame",
                                 where, scan_extent, describe_parts(parts, inside.empty() ? matching : inside)));
  }
  return matching[0];
}

}  // namespace ssc
