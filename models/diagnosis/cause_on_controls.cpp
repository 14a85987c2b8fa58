// The cause on the controls' discretizations (see cause_on_controls.h).
#include "models/diagnosis/cause_on_controls.h"

#include <fmt/format.h>

#include "models/diagnosis/candidates.h"
#include "models/diagnosis/held_out.h"
#include "models/sim/compute_device.h"
#include "models/sim/extensions.h"

namespace ssc {

std::vector<ControlRefit> control_refits(const FittedModel& m, const Scene& scene,
                                         const std::vector<std::string>& controls) {
  const ExtensionRow* row = find_extension(m.name);
  if (!row || row->fit == ExtensionRow::Fit::Measurement || !m.spec) return {};
  std::vector<ControlRefit> out;
  for (const std::string& name : controls) {
    std::string skipped;
    const ModelSpec control = discretization_spec(name, scene, &skipped);
    if (!skipped.empty()) continue;
    ModelSpec spec = *m.spec;
    spec.name = m.name + " with " + name;
    spec.overrides.insert(spec.overrides.end(), control.overrides.begin(), control.overrides.end());
    spec.note = control.note;
    out.push_back({name, spec});
  }
  return out;
}

DiscretizationCheck refit_on_control(const ControlRefit& r, const FittedModel& m, const DiagnosisContext& c,
                                                double phi_max, const std::string& device) {
  DiscretizationCheck check{r.control, {}, {}};
  DiagnosisContext on = c;
  on.phi_max = phi_max;
  on.options.device = device;
  std::vector<std::map<std::string, double>> start = {values_by_name(m)};
  try {
    check.fit = std::move(fit_together({r.spec}, on, start)[0]);
  } catch (const std::exception& e) {
    check.fit.failed = true;
    check.fit.failure = e.what();
  }
  check.fit.proposal = r.spec.note;
  if (!check.fit.failed) check.moved = moved_base(m, check.fit);
  return check;
}

std::vector<DiscretizationCheck> refit_on_controls(const FittedModel& m, const std::vector<std::string>& controls,
                                                   const DiagnosisContext& c, const Scene& scene, double phi_max) {
  const std::vector<ControlRefit> refits = control_refits(m, scene, controls);
  std::vector<DiscretizationCheck> out(refits.size());
  side_by_side(refits.size(), c.options.device, [&](size_t k, const std::string& device) {
    out[k] = refit_on_control(refits[k], m, c, phi_max, device);
  });
  return out;
}

std::string likely_cause(const FittedModel& base, int heldin_frames,
                         const std::map<std::string, FittedModel>& shared_fits, const DiagnosisOptions& o) {
  std::string best;
  double best_gain = o.min_gain;
  for (const auto& [name, m] : shared_fits) {
    if (m.failed || m.frame_costs.size() != base.frame_costs.size() || !m.spec) continue;
    const double g = cost_gain(base.frame_costs, m.frame_costs, heldin_frames, -1, 1, o.seed).value;
    if (g > best_gain) best = name, best_gain = g;
  }
  return best;
}

std::vector<DiscretizationCheck> checks_of(const std::vector<std::string>& controls,
                                           const std::vector<DiscretizationCheck>& early) {
  std::vector<DiscretizationCheck> out;
  for (const std::string& control : controls)
    for (const DiscretizationCheck& check : early)
      if (check.control == control) out.push_back(check);
  return out;
}

std::string control_check_line(const DiscretizationCheck& g, const std::string& cause) {
  const bool grid = g.control == "finer_grid";
  if (g.fit.failed) return fmt::format("the {} fit on {} failed: {}", cause, g.fit.proposal, g.fit.failure);
  if (g.moved.empty()) return fmt::format("on {}, the {} fit moves no parameter by 10 % or more", g.fit.proposal, cause);
  std::string moved;
  for (const auto& [name, here, there] : g.moved)
    moved += fmt::format("{}{} from {} to {} ({:+.0f} %)", moved.empty() ? "" : ", ", name, with_unit(name, here),
                         with_unit(name, there), 100 * (there / here - 1));
  return fmt::format("on {}, the {} fit moves {}: its values depend on the {}; refit {} before trusting them",
                     g.fit.proposal, cause, moved, grid ? "grid" : "time step",
                     grid ? "on the finer grid" : "with the smaller time step");
}

}  // namespace ssc
