// The diagnosis's statistics over frames (see held_out.h).
#include "models/diagnosis/held_out.h"

#include <algorithm>
#include <random>

#include "models/diagnosis/model_fit.h"
#include "models/diagnosis/residuals.h"
#include "models/sim/extensions.h"

namespace ssc {

Gain cost_gain(const std::vector<double>& base, const std::vector<double>& model, int from, int to, int resamples,
               std::uint64_t seed) {
  if (to < 0) to = int(base.size());
  const int n = to - from;
  Gain g;
  if (n <= 0 || model.size() != base.size() || to > int(base.size())) return g;
  auto gain_of = [&](const std::vector<int>& frames) {
    double b = 0, m = 0;
    for (int f : frames) b += base[size_t(from + f)], m += model[size_t(from + f)];
    return b > 0 ? 1 - m / b : 0.0;
  };
  std::vector<int> all(static_cast<size_t>(n));
  for (int f = 0; f < n; ++f) all[size_t(f)] = f;
  g.value = g.low = g.high = gain_of(all);
  if (resamples <= 1) return g;
  const int block = std::max(1, n / 4), blocks = (n + block - 1) / block;
  std::mt19937_64 rng(seed);
  std::uniform_int_distribution<int> start(0, n - block);
  std::vector<double> samples;
  for (int r = 0; r < resamples; ++r) {
    std::vector<int> frames;
    for (int b = 0; b < blocks; ++b) {
      const int s = start(rng);
      for (int k = 0; k < block; ++k) frames.push_back(s + k);
    }
    samples.push_back(gain_of(frames));
  }
  std::sort(samples.begin(), samples.end());
  g.low = samples[size_t(0.05 * double(samples.size() - 1))];
  g.high = samples[size_t(0.95 * double(samples.size() - 1))];
  return g;
}

std::pair<double, double> residual_sum(const std::vector<double>& frame_costs, const Problem& p, int from, int to) {
  double rss = 0, n = 0;
  for (int f = std::max(0, from); f < to && f < int(frame_costs.size()); ++f) {
    const ObservedFrame& frame = p.frames[size_t(f)];
    if (frame.points.empty() || !(frame.weight > 0)) continue;
    rss += 2 * frame_costs[size_t(f)] * double(frame.points.size()) / frame.weight;
    n += double(frame.points.size());
  }
  return {rss, n};
}

int event_frame(const FittedModel& m, const std::string& device) {
  const ExtensionRow* row = find_extension(m.name);
  if (row && row->event == "start") return 0;
  const Residuals r = compute_residuals(m.problem, with_values(m.problem.scene, m.names, m.values), device);
  const int added = row && row->event == "added_plane" ? int(m.problem.scene.planes.size()) - 1 : -1;
  for (const FrameResiduals& f : r.frames)
    if (f.phase == "contact" && (added < 0 || f.plane == added)) return f.frame;
  return -1;
}

}  // namespace ssc
