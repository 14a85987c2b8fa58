// The naming rule of `ssc diagnose` (see naming.h).
#include "models/diagnosis/naming.h"

#include <fmt/format.h>

#include <algorithm>

#include "models/diagnosis/model_fit.h"
#include "models/sim/extensions.h"

namespace ssc {
namespace {

bool is_measurement(const std::string& name) {
  const ExtensionRow* row = find_extension(name);
  return row && row->fit == ExtensionRow::Fit::Measurement;
}

bool clears_heldout_bars(const CandidateVerdict& v, bool measurement, bool control_gained, const DiagnosisOptions& o) {
  const bool over_placebo = v.gain >= o.min_gain && v.gain_low > v.placebo_gain + o.margin && v.implausible.empty();
  if (measurement && control_gained)  // NaN (not laid onto the control) fails
    return over_placebo && v.control_gain >= o.min_gain && v.control_gain_low > v.placebo_gain + o.margin;
  return over_placebo && v.gain_low > v.discretization_gain + o.margin;
}

bool clears_heldin_bar(const CandidateVerdict& v, bool measurement, const DiagnosisOptions& o) {
  return !measurement && v.parameter_free && v.implausible.empty() && v.heldin_gain >= o.min_gain &&
         v.heldin_gain_low > std::max(0.0, v.discretization_heldin_gain) + o.margin && v.gain_high >= 0;
}

}  // namespace

bool clears_bars(const CandidateVerdict& v, bool measurement, bool control_gained, const DiagnosisOptions& o) {
  return clears_heldout_bars(v, measurement, control_gained, o) || clears_heldin_bar(v, measurement, o);
}

bool heldin_bar_only(const CandidateVerdict& v, bool measurement, bool control_gained, const DiagnosisOptions& o) {
  return !clears_heldout_bars(v, measurement, control_gained, o) && clears_heldin_bar(v, measurement, o);
}

void order_named(std::vector<size_t>& named, const std::vector<CandidateVerdict>& verdicts,
                 std::vector<std::string>* unjudged) {
  std::sort(named.begin(), named.end(), [&](size_t a, size_t b) {
    const bool ma = is_measurement(verdicts[a].name), mb = is_measurement(verdicts[b].name);
    if (ma != mb) return ma;
    return verdicts[a].gain > verdicts[b].gain;
  });
  if (unjudged && !named.empty() && is_measurement(verdicts[named[0]].name))
    for (size_t k : named)
      if (!is_measurement(verdicts[k].name)) unjudged->push_back(verdicts[k].name);
}

bool prefer_the_simplest(std::vector<size_t>& named, const std::vector<CandidateVerdict>& verdicts,
                         const std::vector<std::pair<std::string, std::string>>& confounded) {
  if (named.size() < 2 || is_measurement(verdicts[named[0]].name)) return false;
  const std::string& first = verdicts[named[0]].name;
  auto alike = [&](const std::string& other) {
    return std::any_of(confounded.begin(), confounded.end(), [&](const auto& p) {
      return (p.first == first && p.second == other) || (p.first == other && p.second == first);
    });
  };
  size_t best = 0;
  for (size_t k = 1; k < named.size(); ++k)
    if (alike(verdicts[named[k]].name) &&
        verdicts[named[k]].degrees_of_freedom < verdicts[named[best]].degrees_of_freedom)
      best = k;
  if (best == 0) return false;
  std::rotate(named.begin(), named.begin() + std::ptrdiff_t(best), named.begin() + std::ptrdiff_t(best) + 1);
  return true;
}

std::string confounded_line(const std::string& a, const std::string& b, const FittedModel* fa, const FittedModel* fb) {
  std::string line = fmt::format("{} or {}: indistinguishable with this data", a, b);
  std::string values;
  if (fa && fb)
    for (const auto& [name, with_a, with_b] : moved_base(*fa, *fb))
      values += fmt::format("{}{} {} with {}, {} with {}", values.empty() ? "" : "; ", name, with_unit(name, with_a), a,
                            with_unit(name, with_b), b);
  return values.empty() ? line : line + "; " + values + ": these data cannot tell which";
}

}  // namespace ssc
