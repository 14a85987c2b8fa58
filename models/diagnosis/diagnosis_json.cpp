// diagnosis.json (see diagnosis.h).
#include <cmath>

#include "models/diagnosis/candidates.h"
#include "models/diagnosis/diagnosis.h"
#include "models/diagnosis/model_fit.h"

namespace ssc {

nlohmann::json diagnosis_json(const Diagnosis& d) {
  auto named = [](const FittedModel& m, bool extra_only, const std::map<std::string, double>* base) {
    nlohmann::json j = nlohmann::json::object();
    for (size_t i = 0; i < m.names.size() && i < size_t(m.values.size()); ++i)
      if (!extra_only || !base->count(m.names[i])) j[m.names[i]] = m.values[Eigen::Index(i)];
    return j;
  };
  const std::map<std::string, double> base = values_by_name(d.base);
  nlohmann::json j;
  j["cause"] = d.cause;
  j["heldin_frames"] = d.heldin_frames;
  j["heldout_frames"] = d.heldout_frames;
  j["heldout_from_s"] = d.heldout_from;
  auto starts_json = [](const std::vector<FitStart>& starts) {
    nlohmann::json per_start = nlohmann::json::array();
    for (const FitStart& s : starts)
      per_start.push_back({{"stop_reason", s.stop_reason},
                           {"iterations", s.iterations},
                           {"restarts_after_a_stall", s.restarts},
                           {"rounds", s.rounds},
                           {"costs", s.costs}});
    return per_start;
  };
  auto convergence = [&](const FittedModel& m) {
    nlohmann::json c{{"stop_reason", m.stop_reason},
                     {"batches", m.batches},
                     {"converged_starts", m.converged_starts},
                     {"starts", m.starts},
                     {"per_start", starts_json(m.per_start)}};
    for (const OtherProposal& p : m.other_proposals)
      c["other_proposals"].push_back({{"proposal", p.proposal},
                                      {"failed", p.failed},
                                      {"heldin_cost", p.heldin_cost},
                                      {"per_start", starts_json(p.per_start)}});
    return c;
  };
  j["base"] = {{"parameters", named(d.base, false, nullptr)},
               {"heldin_cost", d.base.heldin_cost},
               {"heldout_cost", d.base.heldout_cost},
               {"convergence", convergence(d.base)},
               {"seconds", d.base.seconds}};
  nlohmann::json candidates = nlohmann::json::array();
  for (size_t i = 0; i < d.candidates.size(); ++i) {
    const FittedModel& m = d.candidates[i];
    const CandidateVerdict& v = d.verdicts[i];
    nlohmann::json c;
    c["name"] = v.name;
    c["fitted"] = !m.failed;
    if (!m.failed) {
      c["heldout_before"] = d.base.heldout_cost;
      c["heldout_after"] = m.heldout_cost;
      c["heldin_after"] = m.heldin_cost;
      c["gain"] = v.gain;
      c["gain_low"] = v.gain_low;
      c["gain_high"] = v.gain_high;
      c["placebo_gain"] = v.placebo_gain;
      c["discretization_gain"] = v.discretization_gain;
      c["heldin_gain"] = {v.heldin_gain, v.heldin_gain_low, v.heldin_gain_high};
      c["discretization_heldin_gain"] = v.discretization_heldin_gain;
      c["named_on_heldin"] = v.named_on_heldin;
      if (!std::isnan(v.control_gain)) c["control_gain"] = {v.control_gain, v.control_gain_low};
      c["passes"] = v.passes;
      c["extra_parameters"] = named(m, true, &base);
      nlohmann::json before = nlohmann::json::object(), after = nlohmann::json::object();
      for (size_t k = 0; k < m.names.size(); ++k)
        if (base.count(m.names[k])) before[m.names[k]] = base.at(m.names[k]), after[m.names[k]] = m.values[Eigen::Index(k)];
      c["base_before"] = before;
      c["base_after"] = after;
      c["convergence"] = convergence(m);
      c["seconds"] = m.seconds;
    } else {
      c["passes"] = false;
    }
    c["score"] = std::isnan(v.score) ? nlohmann::json(nullptr) : nlohmann::json(v.score);
    auto number = [](double x) { return std::isnan(x) ? nlohmann::json(nullptr) : nlohmann::json(x); };
    c["event"] = {{"frame", v.event_frame},
                  {"time_s", v.event_frame >= 0 && !m.failed ? nlohmann::json(m.problem.frames[size_t(v.event_frame)].step *
                                                                              m.problem.scene.time.dt)
                                                             : nlohmann::json(nullptr)},
                  {"heldin_gain", number(v.event_gain)},
                  {"aic_difference", number(v.event_aic)}};
    c["implausible"] = v.implausible;
    if (!m.proposal.empty()) c["proposal"] = m.proposal;
    c["warnings"] = v.warnings;
    candidates.push_back(c);
  }
  j["candidates"] = candidates;
  nlohmann::json placebos = nlohmann::json::array();
  for (const FittedModel& p : d.placebos)
    placebos.push_back({{"name", p.name},
                        {"parameters", named(p, true, &base)},
                        {"heldout_cost", p.failed ? nlohmann::json(nullptr) : nlohmann::json(p.heldout_cost)}});
  j["placebos"] = placebos;
  nlohmann::json controls = nlohmann::json::array();
  for (const Diagnosis::Control& k : d.controls) {
    nlohmann::json c{{"name", k.fit.name}, {"fitted", !k.fit.failed}};
    if (k.fit.failed) {
      c["why_not"] = k.fit.failure;
    } else {
      c["what"] = k.fit.proposal;
      c["parameters"] = named(k.fit, false, nullptr);
      c["heldout_cost"] = k.fit.heldout_cost;
      c["gain"] = k.gain;
      c["gain_low"] = k.gain_low;
      c["gain_high"] = k.gain_high;
      c["convergence"] = convergence(k.fit);
      c["seconds"] = k.fit.seconds;
    }
    controls.push_back(c);
  }
  j["discretization_controls"] = controls;
  for (const std::string& control : discretization_controls()) j["cause_on_" + control] = nullptr;
  for (const DiscretizationCheck& g : d.cause_on_controls) {
    nlohmann::json c{{"what", g.fit.proposal}, {"fitted", !g.fit.failed}};
    if (g.fit.failed) {
      c["why_not"] = g.fit.failure;
    } else {
      c["parameters"] = named(g.fit, false, nullptr);
      c["heldin_cost"] = g.fit.heldin_cost;
      c["heldout_cost"] = g.fit.heldout_cost;
      c["convergence"] = convergence(g.fit);
      c["seconds"] = g.fit.seconds;
      nlohmann::json moved = nlohmann::json::array();
      for (const auto& [name, here, there] : g.moved) moved.push_back({{"name", name}, {"fit", here}, {g.control, there}});
      c["moved"] = moved;
    }
    j["cause_on_" + g.control] = c;
  }
  j["undecided"] = nlohmann::json::array();
  for (const auto& [candidate, what] : d.undecided) j["undecided"].push_back({{"candidate", candidate}, {"base", what}});
  j["unjudged"] = d.unjudged;
  if (!d.simpler_than.empty()) j["simpler_than"] = d.simpler_than;
  j["confounded"] = nlohmann::json::array();
  j["confounded_base"] = nlohmann::json::array();  // the base parameters a confounded pair's fits differ in
  for (const auto& [a, b] : d.confounded) {
    j["confounded"].push_back({a, b});
    const FittedModel *fa = candidate_named(d, a), *fb = candidate_named(d, b);
    if (fa && fb)
      for (const auto& [name, with_a, with_b] : moved_base(*fa, *fb))
        j["confounded_base"].push_back({{"models", {a, b}}, {"parameter", name}, {"values", {with_a, with_b}}});
  }
  nlohmann::json id;
  id["parameters"] = d.identifiability.names;
  id["failure"] = d.identifiability.failure;
  id["flat"] = d.identifiability.flat;
  id["correlation"] = nlohmann::json::array();
  for (Eigen::Index i = 0; i < d.identifiability.correlation.rows(); ++i) {
    std::vector<double> row;
    for (Eigen::Index k = 0; k < d.identifiability.correlation.cols(); ++k) row.push_back(d.identifiability.correlation(i, k));
    id["correlation"].push_back(row);
  }
  id["indistinguishable"] = nlohmann::json::array();
  for (const auto& [a, b, r] : d.indistinguishable) id["indistinguishable"].push_back({{"a", a}, {"b", b}, {"correlation", r}});
  j["identifiability"] = id;
  j["slices"] = nlohmann::json::array();
  for (const ParameterSlice& s : d.slices)
    j["slices"].push_back({{"parameter", s.name}, {"fitted", s.fitted}, {"values", s.values}, {"costs", s.costs},
                           {"low", s.low}, {"high", s.high}, {"open_low", s.open_low}, {"open_high", s.open_high}});
  j["lines"] = d.lines;
  j["seconds"] = d.seconds;
  return j;
}

}  // namespace ssc
