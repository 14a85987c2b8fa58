// The residual parts of the report's data (see report_data.h).
#include "models/diagnosis/report_data.h"

#include <algorithm>
#include <cmath>

namespace ssc {
namespace {

nlohmann::json millimetres_or_null(bool matched, double metres) {
  return matched ? nlohmann::json(1e3 * metres) : nlohmann::json(nullptr);
}

// Residual images of one frame, one per camera, in millimetres (null: no matched point).
std::vector<nlohmann::json> frame_images(const Problem& problem, const Residuals& r, int frame) {
  std::vector<nlohmann::json> out;
  const auto& images = problem.observations.frames[size_t(frame)];
  for (size_t c = 0; c < images.size(); ++c) {
    nlohmann::json values = nlohmann::json::array();
    for (int i = 0; i < images[c].width * images[c].height; ++i) values.push_back(nullptr);
    out.push_back(values);
  }
  for (const ResidualPoint& p : r.points)
    if (p.frame == frame && p.camera < int(out.size()) && p.pixel >= 0)
      out[size_t(p.camera)][size_t(p.pixel)] = millimetres_or_null(p.matched, p.residual);
  return out;
}

}  // namespace

void add_residual_report_data(nlohmann::json& data, const Problem& problem, const Residuals& before,
                              const Residuals* after, int images) {
  nlohmann::json t;
  for (size_t f = 0; f < before.frames.size(); ++f) {
    t["time"].push_back(before.frames[f].time);
    t["before_mm"].push_back(before.frames[f].matched ? nlohmann::json(1e3 * before.frames[f].rms) : nlohmann::json(nullptr));
    if (after && f < after->frames.size())
      t["after_mm"].push_back(after->frames[f].matched ? nlohmann::json(1e3 * after->frames[f].rms) : nlohmann::json(nullptr));
  }
  t["contact_times"] = before.contact_times;
  data["residual_vs_time"] = t;

  const int n = int(before.frames.size());
  std::vector<int> chosen;
  for (int k = 1; k <= images && n > 0; ++k) {
    const int f = std::clamp(int(std::round(double(k) / images * (n - 1))), 0, n - 1);
    if (std::find(chosen.begin(), chosen.end(), f) == chosen.end()) chosen.push_back(f);
  }
  data["residual_images"] = nlohmann::json::array();
  for (int f : chosen) {
    if (size_t(f) >= problem.observations.frames.size()) continue;
    const std::vector<nlohmann::json> b = frame_images(problem, before, f);
    const std::vector<nlohmann::json> a = after ? frame_images(problem, *after, f) : std::vector<nlohmann::json>();
    for (size_t c = 0; c < b.size(); ++c) {
      const DepthCamera& cam = problem.observations.cameras[c];
      nlohmann::json im = {{"camera", cam.name},
                           {"frame", f},
                           {"time", before.frames[size_t(f)].time},
                           {"width", problem.observations.frames[size_t(f)][c].width},
                           {"height", problem.observations.frames[size_t(f)][c].height},
                           {"before_mm", b[c]}};
      if (after) im["after_mm"] = a[c];
      data["residual_images"].push_back(im);
    }
  }

  // The rest shape: matched points of the base fit, every k-th, with the same observed
  // point's residual after.
  nlohmann::json rest;
  rest["points"] = nlohmann::json::array();
  size_t matched = 0;
  for (const ResidualPoint& p : before.points) matched += p.matched;
  const size_t every = std::max<size_t>(1, matched / 4000 + 1);
  size_t seen = 0;
  const bool same_points = after && after->points.size() == before.points.size();
  for (size_t i = 0; i < before.points.size(); ++i) {
    const ResidualPoint& p = before.points[i];
    if (!p.matched || seen++ % every) continue;
    rest["points"].push_back({p.rest.x(), p.rest.y(), p.rest.z()});
    rest["before_mm"].push_back(1e3 * p.residual);
    if (same_points) rest["after_mm"].push_back(millimetres_or_null(after->points[i].matched, after->points[i].residual));
  }
  data["rest_shape"] = rest;
}

}  // namespace ssc
