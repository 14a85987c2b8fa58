// `ssc diagnose` (see diagnosis.h): diagnose() reads as its steps.
#include "models/diagnosis/diagnosis.h"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <functional>
#include <mutex>
#include <set>
#include <thread>

#include "models/diagnosis/candidates.h"
#include "models/diagnosis/cause_on_controls.h"
#include "models/diagnosis/held_out.h"
#include "models/diagnosis/interface_search.h"
#include "models/diagnosis/measurement_fit.h"
#include "models/diagnosis/model_fit.h"
#include "models/diagnosis/naming.h"
#include "models/diagnosis/score_test.h"
#include "models/sim/compute_device.h"
#include "models/sim/parameters.h"
#include "runtime/errors.h"
#include "runtime/ranks.h"

namespace ssc {
namespace {

// At most this many proposed planes are fitted (as one batch).
constexpr int kPlaneProposals = 3;
// Seconds between two progress lines from within the fits.
constexpr double kRoundLines = 10;
// A fit within this fraction of a plausible range's end (of its logarithm for a range over
// more than two decades) sits at the end.
constexpr double kAtEnd = 0.01;

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

std::string percent(double x) { return fmt::format("{:.0f} %", 100 * x); }

// "youngs_modulus = 5e+04 Pa, ..." of a fit.
std::string values_text(const FittedModel& m) {
  std::string out;
  for (size_t i = 0; i < m.names.size(); ++i)
    out += fmt::format("{}{} = {}", out.empty() ? "" : ", ", m.names[i], with_unit(m.names[i], m.values[Eigen::Index(i)]));
  return out;
}

// Step 0: the frames' split and the body's size, from the scene and observations as loaded.
DiagnosisContext prepare(Diagnosis& d, const std::string& scene_path, const std::vector<std::string>& overrides,
                         const std::string& observations, double phi_max, const DiagnosisOptions& o, Scene* scene) {
  for (const std::string& name : o.candidates)
    if (!find_extension(name))
      throw InputError(fmt::format("--candidates: unknown candidate '{}'; known: {}", name, extension_list()));
  if (!(o.holdout > 0 && o.holdout < 1)) throw InputError("--holdout must be in (0, 1)");
  DiagnosisContext c{scene_path, overrides, observations, phi_max, o, 0, 1, {}};
  const Problem probe = load_problem(scene_path, overrides, observations, phi_max, o.fit);
  const int n = int(probe.frames.size());
  d.heldin_frames = std::max(2, int(std::ceil((1 - o.holdout) * n)));
  d.heldout_frames = n - d.heldin_frames;
  if (d.heldout_frames < 2)
    throw InputError(fmt::format("{}: {} observed frames leave fewer than 2 to hold out at --holdout {}; observe more "
                                 "frames or raise --holdout",
                                 observations, n, o.holdout));
  d.heldout_from = probe.frames[size_t(d.heldin_frames)].step * probe.scene.time.dt;
  c.heldin = d.heldin_frames;
  c.extent = rest_extent(probe.grid);
  *scene = probe.scene;
  return c;
}

// Step 1: the base model, its placebos (one per count of extra parameters a candidate has, at
// most 3: beyond, the 3-parameter placebo's gain is scaled) and the candidates with an off
// value, as one batch.
std::map<std::string, FittedModel> fit_shared(Diagnosis& d, const DiagnosisContext& c, const Scene& scene,
                                              std::vector<std::map<std::string, double>>& base_starts,
                                              Problem& shared_problem, std::map<std::string, std::string>& skipped,
                                              const DiagnosisProgress& say) {
  std::vector<ModelSpec> specs = {ModelSpec{"base"}};
  const std::vector<std::string> spare = placebo_parameters(scene, c.options.fit);
  const int most = std::min(3, int(spare.size()));
  std::set<int> counts;
  for (const std::string& name : c.options.candidates)
    if (const int k = extra_parameter_count(*find_extension(name), scene); k > 0 && most > 0) counts.insert(std::min(k, most));
  for (int k : counts) specs.push_back(placebo_spec(scene, spare, k));
  const size_t placebos = specs.size() - 1;
  for (const std::string& name : c.options.candidates) {
    const ExtensionRow& row = *find_extension(name);
    if (row.fit != ExtensionRow::Fit::OffValue) continue;
    if (extra_parameter_count(row, scene) == 0)
      skipped[name] = "the scene has nothing it acts on (no ground plane)";
    else
      specs.push_back(candidate_spec(row, scene, c.extent));
  }
  std::string together;
  for (size_t i = 1; i < specs.size(); ++i) together += (i > 1 ? ", " : "") + specs[i].name;
  say(fmt::format("fitting the base model with {} as one batch of {} starts", together,
                  specs.size() * size_t(c.options.starts)));
  std::vector<FittedModel> fitted = fit_together(specs, c, base_starts, &shared_problem);
  say(fmt::format("the batch of the base model with {} done", together));
  d.base = std::move(fitted[0]);
  if (d.base.failed) throw SimulationError("the base model's fit failed at every start: " + d.base.failure);
  for (size_t k = 0; k < placebos; ++k) d.placebos.push_back(std::move(fitted[1 + k]));
  std::map<std::string, FittedModel> fits;
  for (size_t i = 1 + placebos; i < fitted.size(); ++i) fits[fitted[i].name] = std::move(fitted[i]);
  return fits;
}

// The two_materials model at the searched interface, with what the search did.
ModelSpec interface_spec(const InterfaceSearch& s, const InterfaceGuess& from, const Eigen::Vector3d& centre) {
  const Eigen::Vector3d& n = s.best.normal;
  const double turned = std::acos(std::clamp(n.dot(from.normal), -1.0, 1.0)) * 180 / 3.14159265358979323846;
  return two_materials_spec(n, s.best.offset, s.best.modulus,
                            fmt::format("an interface facing ({:.2f}, {:.2f}, {:.2f}), {:.1f} mm from the centre of "
                                        "mass, {:.0f} degrees from the fitted stiffness gradient: the best of {} "
                                        "geometries on the held-in frames ({:.0f} % below the gradient's)",
                                        n.x(), n.y(), n.z(), 1e3 * (s.best.offset - n.dot(centre)), turned, s.geometries,
                                        100 * (1 - s.heldin_cost / s.start_cost)));
}

// Step 3: a candidate that needs a batch of its own: a model switch, proposed planes (the
// best of them), a proposed interface.
FittedModel fit_own(const ExtensionRow& row, const Diagnosis& d, const DiagnosisContext& c, const Scene& scene,
                    const std::map<std::string, FittedModel>& shared_fits,
                    std::vector<std::map<std::string, double>>& base_starts, std::string* skipped) {
  if (row.fit == ExtensionRow::Fit::Measurement) return fit_measurement(row, d.base, c, base_starts);
  std::vector<ModelSpec> specs;
  std::vector<std::map<std::string, double>> starts = base_starts;
  if (row.fit == ExtensionRow::Fit::ModelSwitch) {
    specs.push_back(candidate_spec(row, scene, c.extent));
  } else if (row.fit == ExtensionRow::Fit::ProposedPlane) {
    specs = plane_proposals(d.base, c.heldin, kPlaneProposals);
    if (specs.empty())
      *skipped = "the fitted body never went beyond the observed points by half a cell: no plane to propose";
  } else if (row.fit == ExtensionRow::Fit::ProposedRegion) {
    const auto gradient = shared_fits.find("heterogeneous_stiffness");
    if (!scene.material.regions.empty())
      *skipped = "the scene already has material regions";
    else if (gradient == shared_fits.end())
      *skipped = "its interface is proposed from the heterogeneous_stiffness fit, which was not run";
    else if (const InterfaceGuess guess = interface_proposal(gradient->second, d.base.problem, c.extent); !guess.found())
      *skipped = "the fitted stiffness gradient changes the modulus by less than 10 % across the body: no interface "
                 "to propose";
    else {
      const InterfaceSearch search = search_interface(d.base, guess, c);
      specs.push_back(interface_spec(search, guess, d.base.problem.grid.start_center_of_mass()));
      // One start more: the base's fit with both sides' moduli where the search found them.
      std::map<std::string, double> found = values_by_name(d.base);
      if (found.count("youngs_modulus") && search.best.body_modulus > 0) found["youngs_modulus"] = search.best.body_modulus;
      found[specs.back().extra[0]] = search.best.modulus;
      starts.insert(starts.begin(), found);
    }
  }
  if (!skipped->empty()) return FittedModel{};
  std::vector<FittedModel> fits = fit_together(specs, c, starts, nullptr, specs.size() > 1);
  size_t best = 0;
  for (size_t i = 1; i < fits.size(); ++i)
    if (fits[best].failed || (!fits[i].failed && fits[i].heldin_cost < fits[best].heldin_cost)) best = i;
  fits[best].proposal = specs[best].note;
  if (fits.size() > 1) fits[best].proposal += fmt::format(" (the best of {} proposals, fitted as one batch)", fits.size());
  for (size_t i = 0; i < fits.size(); ++i)
    if (i != best) fits[best].other_proposals.push_back({specs[i].note, fits[i].failed, fits[i].heldin_cost, fits[i].per_start});
  return std::move(fits[best]);
}

bool is_control(const std::string& name) {
  const std::vector<std::string>& c = discretization_controls();
  return std::find(c.begin(), c.end(), name) != c.end();
}

// Step 3 for a discretization control: the base model on a finer discretization, started from
// the base's fit and from the base's own starts (the base's fit has absorbed some of the
// discretization error it is a control for: a spinning brick's 153 kPa for ccx's 80). Its cost
// keeps the base's phi_max (by default two of the base's cells): on a finer grid's own, every
// point far from the body would cost a quarter as much.
FittedModel fit_control(const std::string& control, const Diagnosis& d, const DiagnosisContext& c, const Scene& scene,
                        const std::vector<std::map<std::string, double>>& base_starts, std::string* skipped) {
  const ModelSpec spec = discretization_spec(control, scene, skipped);
  if (!skipped->empty()) return FittedModel{};
  DiagnosisContext same_cost = c;
  same_cost.phi_max = d.base.problem.phi_max;
  std::vector<std::map<std::string, double>> start = {values_by_name(d.base)};
  start.insert(start.end(), base_starts.begin(), base_starts.end());
  FittedModel m = std::move(fit_together({spec}, same_cost, start)[0]);
  m.proposal = spec.note;
  return m;
}

// Fits side by side on one GPU. On the 360-step timing case (docs/benchmarks.md, "Several
// GPUs"): two, 72 s against 89 s one after the other on one H200 machine, the same
// diagnosis.json; since the `lm` secant term and the restarts, 138.2, 133.5 and 127.5 s with
// two, three and four (one H200 of a four-H200 machine, 2026-11-27, the same diagnosis.json).
constexpr int kFitsPerGpu = 4;

// A fit's cost relative to the others', to start the costliest first: half the time step
// doubles the steps; an interface search or several plane proposals fit many models; a
// measurement correction is refitted only where it gains. From the timing case's log on
// two H200 (docs/benchmarks.md, "Several GPUs").
double schedule_weight(const std::string& name) {
  if (name == "finer_step") return 5;
  if (name == "finer_grid") return 2;
  const ExtensionRow* row = find_extension(name);
  if (!row) return 1;
  switch (row->fit) {
    case ExtensionRow::Fit::ProposedRegion: return 4;
    case ExtensionRow::Fit::ModelSwitch: return 3;
    case ExtensionRow::Fit::ProposedPlane: return 3;
    case ExtensionRow::Fit::OffValue: return 1;
    case ExtensionRow::Fit::Measurement: return 0.5;
  }
  return 1;
}

// A refit of the likely cause on a control's discretization runs one start from its fitted
// values where the control's own fit runs nine: on the timing case about 12 and 27 s against
// 22 and 37 s (one H200, four fits a GPU), so about this share of the control's weight.
constexpr double kEarlyRefitShare = 0.6;

// The GPUs of step 3's fits, one entry a thread: kFitsPerGpu per GPU (SSC_FITS_PER_GPU=N: N),
// the GPUs taking turns, so that the costliest fits start on different GPUs. Empty on the CPU
// or with several ranks.
std::vector<int> fit_threads(const DiagnosisContext& c) {
  std::vector<int> gpus;
  if (runs_on_gpu(c.options.device) && ranks::count() == 1) {
    const char* per = std::getenv("SSC_FITS_PER_GPU");
    for (int k = 0, n = per ? std::max(1, std::atoi(per)) : kFitsPerGpu; k < n; ++k)
      for (int g : device_gpus(c.options.device)) gpus.push_back(g);
  }
  return gpus;
}

// Step 3 for every candidate the shared batch did not fit, in `order`, and the
// discretization controls where asked for, and the jobs of `after` (each given its device,
// weighed by `after_weights`), the costliest first. On the GPU (with one rank) the jobs run
// side by side, a thread of fit_threads() each taking the next one; a fit's result does not
// depend on which GPU ran it or what ran beside it. A skipped fit's reason goes to `skipped`.
std::map<std::string, FittedModel> fit_own_all(const Diagnosis& d, const DiagnosisContext& c, const Scene& scene,
                                               const std::vector<std::string>& order,
                                               const std::map<std::string, FittedModel>& shared_fits,
                                               std::vector<std::map<std::string, double>>& base_starts,
                                               std::map<std::string, std::string>& skipped,
                                               const std::function<void(const std::string&)>& say,
                                               const std::vector<std::function<void(const std::string&)>>& after,
                                               const std::vector<double>& after_weights) {
  std::vector<std::string> names;
  if (c.options.discretization_controls)
    for (const std::string& control : discretization_controls()) names.push_back(control);
  for (const std::string& name : order)
    if (!shared_fits.count(name) && !skipped.count(name)) names.push_back(name);
  std::vector<FittedModel> fits(names.size());
  std::vector<std::string> why(names.size());
  auto fit = [&](size_t k, const DiagnosisContext& on) {
    say("fitting " + (is_control(names[k]) ? "the base model, " + names[k] : names[k]) +
        (on.options.device == c.options.device ? "" : " on " + on.options.device));
    try {
      fits[k] = is_control(names[k])
                    ? fit_control(names[k], d, on, scene, base_starts, &why[k])
                    : fit_own(*find_extension(names[k]), d, on, scene, shared_fits, base_starts, &why[k]);
    } catch (const std::exception& e) {
      fits[k].failed = true;
      fits[k].failure = e.what();
    }
    say((is_control(names[k]) ? "the base model, " + names[k] : names[k]) + " done");
  };
  // Jobs 0 .. names.size() - 1 are the fits, the rest those of `after`.
  std::vector<size_t> jobs(names.size() + after.size());
  for (size_t k = 0; k < jobs.size(); ++k) jobs[k] = k;
  auto weight = [&](size_t k) { return k < names.size() ? schedule_weight(names[k]) : after_weights[k - names.size()]; };
  std::stable_sort(jobs.begin(), jobs.end(), [&](size_t a, size_t b) { return weight(a) > weight(b); });
  auto job = [&](size_t k, const DiagnosisContext& on) {
    if (k < names.size())
      fit(k, on);
    else
      after[k - names.size()](on.options.device);
  };
  const std::vector<int> gpus = fit_threads(c);
  if (gpus.size() <= 1 || jobs.size() <= 1) {
    for (size_t k : jobs) job(k, c);
  } else {
    std::atomic<size_t> next{gpus.size()};
    std::vector<std::thread> workers;
    for (size_t w = 0; w < gpus.size(); ++w)
      workers.emplace_back([&, w] {
        DiagnosisContext on = c;
        on.options.device = gpu_device(gpus[w]);
        for (size_t i = w; i < jobs.size(); i = next++) job(jobs[i], on);  // thread w starts with job w
      });
    for (std::thread& w : workers) w.join();
  }
  std::map<std::string, FittedModel> out;
  for (size_t k = 0; k < names.size(); ++k) {
    if (!why[k].empty()) skipped[names[k]] = why[k];
    out[names[k]] = std::move(fits[k]);
  }
  return out;
}

// The fit's parameters at an end of their plausible range.
std::vector<std::string> implausible_values(const FittedModel& m, double extent) {
  std::vector<std::string> out;
  for (size_t i = 0; i < m.names.size(); ++i) {
    const std::string& name = m.names[i];
    std::string source;
    const auto [lo, hi] = plausible_range(m.problem.scene, name, extent, &source);
    if (!std::isfinite(lo) && !std::isfinite(hi)) continue;
    const double v = m.values[Eigen::Index(i)];
    const ExtensionRow* row = find_extension(owner(name));
    const bool lower_is_off = row && row->one_sided && lo == row->off_value;
    double t = 0.5;  // where v lies in the range, 0 .. 1
    if (std::isfinite(lo) && std::isfinite(hi))
      t = lo > 0 && hi / lo > 100 && v > 0 ? std::log(v / lo) / std::log(hi / lo) : (v - lo) / (hi - lo);
    else if (std::isfinite(lo))
      t = v <= lo ? 0 : 0.5;
    else
      t = v >= hi ? 1 : 0.5;
    const bool upper = t > 1 - kAtEnd, lower = t < kAtEnd && !lower_is_off;
    if (upper || lower)
      out.push_back(fmt::format("{} = {} at the {} end of its plausible range [{:g}, {:g}] ({})", name,
                                with_unit(name, v), upper ? "upper" : "lower", lo, hi, source));
  }
  return out;
}

// Step 4: each candidate's gain against its placebo and the discretization controls, its
// plausibility and its event.
void judge(Diagnosis& d, const DiagnosisContext& c, std::vector<size_t>& named) {
  const DiagnosisOptions& o = c.options;
  double discretization = 0, discretization_heldin = 0;
  const Diagnosis::Control* finest = nullptr;  // the control with the largest gain
  for (Diagnosis::Control& k : d.controls)
    if (!k.fit.failed && !k.fit.frame_costs.empty()) {
      const Gain g = cost_gain(d.base.frame_costs, k.fit.frame_costs, d.heldin_frames, -1, o.bootstrap, o.seed + 57);
      k.gain = g.value, k.gain_low = g.low, k.gain_high = g.high;
      discretization = std::max(discretization, g.value);
      discretization_heldin = std::max(
          discretization_heldin, cost_gain(d.base.frame_costs, k.fit.frame_costs, 0, d.heldin_frames, 1, o.seed).value);
      if (!finest || k.gain > finest->gain) finest = &k;
    }
  const size_t most = d.placebos.empty() ? 0 : d.placebos.back().extra.size();
  auto placebo_gain = [&](size_t extra) {
    if (extra == 0) return 0.0;
    for (const FittedModel& p : d.placebos)
      if (p.extra.size() == std::min(extra, most)) {
        if (p.failed) return 0.0;
        const double g = cost_gain(d.base.frame_costs, p.frame_costs, d.heldin_frames, -1, 1, o.seed).value;
        return g * double(extra) / double(p.extra.size());
      }
    return 0.0;
  };
  std::vector<int> events(d.candidates.size(), -1);  // side by side: each simulates every frame
  std::vector<std::string> event_failures(d.candidates.size());
  side_by_side(d.candidates.size(), o.device, [&](size_t i, const std::string& device) {
    if (d.candidates[i].failed) return;
    try {
      events[i] = event_frame(d.candidates[i], device);
    } catch (const std::exception& e) {
      event_failures[i] = e.what();
    }
  });
  for (size_t i = 0; i < d.candidates.size(); ++i) {
    FittedModel& m = d.candidates[i];
    CandidateVerdict& v = d.verdicts[i];
    if (m.failed) continue;
    const ExtensionRow* row = find_extension(m.name);
    const size_t extra = row && row->fit == ExtensionRow::Fit::Measurement
                             ? m.extra.size()
                             : expand_parameter_names(m.extra, PhysicalParameters::from_scene(m.problem.scene)).size();
    const Gain g = cost_gain(d.base.frame_costs, m.frame_costs, d.heldin_frames, -1, o.bootstrap, o.seed + i);
    v.gain = g.value, v.gain_low = g.low, v.gain_high = g.high;
    const Gain in = cost_gain(d.base.frame_costs, m.frame_costs, 0, d.heldin_frames, o.bootstrap, o.seed + 7 * i);
    v.heldin_gain = in.value, v.heldin_gain_low = in.low, v.heldin_gain_high = in.high;
    v.placebo_gain = std::max(0.0, placebo_gain(extra));
    v.discretization_gain = discretization;
    v.discretization_heldin_gain = discretization_heldin;
    v.parameter_free = extra == 0;
    v.degrees_of_freedom = int(extra) + (row ? row->searched_degrees_of_freedom : 0);
    v.implausible = implausible_values(m, c.extent);
    const bool measurement = row && row->fit == ExtensionRow::Fit::Measurement;
    const bool control_gained = finest && finest->gain > 0;
    // A correction of the recording stands for nothing the model's discretization could: where
    // it would pass the other bars, it is fitted again with the finest control's physics, as it
    // was with the base's, to see what it explains beyond it.
    if (measurement && control_gained && v.gain >= o.min_gain && v.gain_low > v.placebo_gain + o.margin &&
        v.implausible.empty()) {
      try {
        DiagnosisContext same_cost = c;
        same_cost.phi_max = d.base.problem.phi_max;
        const FittedModel over = measurement_on(*row, finest->fit, same_cost);
        const Gain gc = cost_gain(finest->fit.frame_costs, over.frame_costs, d.heldin_frames, -1, o.bootstrap,
                                  o.seed + 31 * i);
        v.control_gain = gc.value, v.control_gain_low = gc.low;
      } catch (const std::exception& e) {
        v.warnings.push_back(std::string("not laid onto the ") + finest->fit.name + " control's motion: " + e.what());
      }
    }
    v.passes = clears_bars(v, measurement, control_gained, o);
    v.named_on_heldin = heldin_bar_only(v, measurement, control_gained, o);
    if (v.passes) named.push_back(i);
    v.event_frame = events[i];
    if (!event_failures[i].empty()) v.warnings.push_back("the event's frame was not found: " + event_failures[i]);
    if (v.event_frame >= 0 && v.event_frame < d.heldin_frames) {
      const auto [rss_base, n] = residual_sum(d.base.frame_costs, m.problem, v.event_frame, d.heldin_frames);
      const double rss = residual_sum(m.frame_costs, m.problem, v.event_frame, d.heldin_frames).first;
      if (rss_base > 0 && rss > 0) {
        v.event_gain = 1 - rss / rss_base;
        v.event_aic = n * std::log(rss / rss_base) + 2.0 * double(extra);
      }
    }
  }
  order_named(named, d.verdicts, &d.unjudged);
  for (size_t a = 0; a < named.size(); ++a)
    for (size_t b = a + 1; b < named.size(); ++b) {
      // Indistinguishable: the gain of one over the other has an interval containing 0.
      const Gain diff = cost_gain(d.candidates[named[b]].frame_costs, d.candidates[named[a]].frame_costs,
                                  d.heldin_frames, -1, o.bootstrap, o.seed + 99);
      if (diff.low <= 0) d.confounded.push_back({d.verdicts[named[a]].name, d.verdicts[named[b]].name});
    }
  if (!named.empty()) {
    const size_t first = named[0];
    if (prefer_the_simplest(named, d.verdicts, d.confounded))
      d.simpler_than = fmt::format(
          "{} and {} predict the held-out frames alike ({} and {}); named {}, the simpler ({} degrees of freedom "
          "against {})",
          d.verdicts[named[0]].name, d.verdicts[first].name, percent(d.verdicts[named[0]].gain),
          percent(d.verdicts[first].gain), d.verdicts[named[0]].name, d.verdicts[named[0]].degrees_of_freedom,
          d.verdicts[first].degrees_of_freedom);
    d.cause = d.verdicts[named[0]].name;
  }
}

// The controls that ran, in the order of discretization_controls().
std::vector<std::string> controls_that_ran(const Diagnosis& d) {
  std::vector<std::string> out;
  for (const Diagnosis::Control& k : d.controls)
    if (!k.fit.failed && !k.fit.frame_costs.empty()) out.push_back(k.fit.name);
  return out;
}

// Step 5 (with no cause): candidates the data cannot tell from the base. Both gains, on the
// held-in and on the held-out frames, have an interval containing 0 or are within 2 margins
// of it, and the candidate moves a base parameter.
void find_undecided(Diagnosis& d, const DiagnosisContext& c) {
  if (d.cause != "none") return;
  const DiagnosisOptions& o = c.options;
  auto even = [&](const Gain& g) { return (g.low <= 0 && g.high >= 0) || std::abs(g.value) < 2 * o.margin; };
  for (size_t i = 0; i < d.candidates.size(); ++i) {
    const FittedModel& m = d.candidates[i];
    const CandidateVerdict& v = d.verdicts[i];
    if (m.failed) continue;
    if (!even({v.heldin_gain, v.heldin_gain_low, v.heldin_gain_high}) || !even({v.gain, v.gain_low, v.gain_high})) continue;
    for (const auto& [name, before, after] : moved_base(d.base, m))
      d.undecided.emplace_back(m.name, fmt::format("{} {} with the base model, {} with {}", name, with_unit(name, before),
                                                   with_unit(name, after), m.name));
  }
}

// Step 6: identifiability at the cause's fit m, over m's parameters, the mass damping and
// (shared: the graph m was fitted in, with every extension that has an off value) the other
// candidates' parameters at off. Steps: 1e-3 of a value, 1e-2 of a typical amount at 0
// (forward, so that friction and drag stay valid).
// The cause's fit m as a point of the problem it is simulated in: the shared batch's (every
// extension with an off value present, the others' at off, as m was fitted) or its own; m's
// simulation parameters at their fitted values (a measurement's correction is in the problem's
// frames, not the simulation's). `off` receives the parameters set to off.
PhysicalParameters fit_point(const FittedModel& m, const Problem& problem, bool shared, std::vector<std::string>* off) {
  PhysicalParameters at = PhysicalParameters::from_scene(problem.scene);
  if (shared)
    for (const ExtensionRow& row : extension_table()) {
      if (row.fit != ExtensionRow::Fit::OffValue) continue;
      for (const std::string& n : expand_parameter_names(row.parameters(problem.scene), at)) {
        set_parameter(at, n, row.off_value);
        if (off) off->push_back(n);
      }
    }
  for (size_t i = 0; i < m.names.size(); ++i)
    if (!is_measurement_parameter(m.names[i])) set_parameter(at, m.names[i], m.values[Eigen::Index(i)]);
  return at;
}

void identifiability_at(Diagnosis& d, const FittedModel& m, const Problem* shared, const DiagnosisContext& c) {
  const Problem& problem = shared ? *shared : m.problem;
  std::vector<std::string> off;
  const PhysicalParameters at = fit_point(m, problem, shared != nullptr, &off);
  std::vector<std::string> names;
  for (const std::string& n : m.names)
    if (!is_measurement_parameter(n)) names.push_back(n);
  for (const std::string& n : off)
    if (std::find(names.begin(), names.end(), n) == names.end()) names.push_back(n);
  if (std::find(names.begin(), names.end(), "mass_damping") == names.end()) names.push_back("mass_damping");
  std::vector<double> steps;
  for (const std::string& n : names) {
    const double v = get_parameter(at, n);
    const ExtensionRow* row = find_extension(owner(n));
    const double typical = row && row->typical ? row->typical(c.extent) : 1.0;
    steps.push_back(v != 0 ? 1e-3 * std::abs(v) : 1e-2 * typical);
  }
  d.identifiability = parameter_correlation(held_in(problem, d.heldin_frames), at, names, steps, c.options.device);
  if (!d.identifiability.failure.empty()) return;
  names = d.identifiability.names;
  for (size_t i = 0; i < names.size(); ++i)
    for (size_t j = i + 1; j < names.size(); ++j) {
      const double r = d.identifiability.correlation(Eigen::Index(i), Eigen::Index(j));
      if (std::abs(r) < 0.95) continue;
      d.indistinguishable.emplace_back(names[i], names[j], r);
      const std::string a = owner(names[i]), b = owner(names[j]);
      if (a == b || (a != m.name && b != m.name)) continue;
      const std::string other = a == m.name ? b : a;
      const bool listed = std::any_of(d.confounded.begin(), d.confounded.end(), [&](const auto& p) {
        return (p.first == m.name && p.second == other) || (p.first == other && p.second == m.name);
      });
      if (!listed && (other == "mass_damping" || find_extension(other))) d.confounded.push_back({m.name, other});
    }
}

// The rise of the held-in cost, as a fraction of the cause's fitted cost, within which a value
// of one of its parameters counts as fitting as well as the fitted one. (Not a fraction of the
// cause's gain: a cube at rest on a slope gains 150 times its fitted cost by friction, and a
// friction that lets it creep costs 150 times as much again: tests/test_parameter_slices.cpp.)
constexpr double kSliceTolerance = 0.05;

// Probes a side of a slice: at 1/64, 1/32, ..., 1/2 and all of the way to the range's end.
constexpr int kSliceProbes = 7;
// A parameter sliced in log space (the Young's modulus: 10 Pa to 1.2 TPa) is probed at most this
// factor either way from its fit: a body a million times stiffer than fitted tells nothing more
// and its solves take many times as long.
constexpr double kSliceFactor = 1000;

// Step 6b: the held-in cost along each of the cause's simulation parameters, the base's
// included (the others at the fit), out to the ends of its plausible range, as one batch.
void slices_at(Diagnosis& d, const FittedModel& m, const Problem* shared, const DiagnosisContext& c) {
  const Problem& problem = shared ? *shared : m.problem;
  const PhysicalParameters at = fit_point(m, problem, shared != nullptr, nullptr);
  std::vector<std::string> names;
  std::vector<std::pair<double, double>> ranges;
  std::vector<bool> log_scale;
  for (size_t i = 0; i < m.names.size(); ++i) {
    const std::string& n = m.names[i];
    if (is_measurement_parameter(n)) continue;
    auto [lo, hi] = plausible_range(m.problem.scene, n, c.extent);
    if (!std::isfinite(lo) && !std::isfinite(hi)) continue;
    const double v = m.values[Eigen::Index(i)];
    const bool log = lo > 0 && hi / lo > 100;
    if (log && v > 0) lo = std::max(lo, v / kSliceFactor), hi = std::min(hi, v * kSliceFactor);
    names.push_back(n);
    ranges.emplace_back(lo, hi);
    log_scale.push_back(log);
  }
  if (names.empty()) return;
  d.slices = slice_parameters(held_in(problem, d.heldin_frames), at, names, ranges, log_scale, kSliceTolerance,
                              kSliceProbes, c.options.device);
}

// Step 7: what to tell the user.
void tell(Diagnosis& d, const DiagnosisOptions& o, const std::vector<size_t>& named) {
  const std::map<std::string, double> base_values = values_by_name(d.base);
  if (named.empty()) {
    size_t best = d.verdicts.size();
    for (size_t i = 0; i < d.verdicts.size(); ++i)
      if (!d.candidates[i].failed && d.verdicts[i].implausible.empty() &&
          (best == d.verdicts.size() || d.verdicts[i].gain > d.verdicts[best].gain))
        best = i;
    d.lines.push_back(fmt::format("cause: none. No candidate removes {} of the held-out residual and beats its placebo "
                                  "{}by {} points{}",
                                  percent(o.min_gain), d.controls.empty() ? "" : "and the discretization controls ",
                                  100 * o.margin,
                                  best < d.verdicts.size()
                                      ? fmt::format(" (the best, {}, removes {}, interval {} .. {})", d.verdicts[best].name,
                                                    percent(d.verdicts[best].gain), percent(d.verdicts[best].gain_low),
                                                    percent(d.verdicts[best].gain_high))
                                      : ""));
  } else {
    const CandidateVerdict& v = d.verdicts[named[0]];
    const FittedModel& m = d.candidates[named[0]];
    if (v.named_on_heldin)
      d.lines.push_back(fmt::format(
          "cause: {}. With no parameter of its own it removes {} of the held-in residual (90 % interval {} .. {}; "
          "the discretization controls: {}), and {} of the held-out residual (interval {} .. {}): the held-out "
          "frames cannot tell, the held-in ones can",
          v.name, percent(v.heldin_gain), percent(v.heldin_gain_low), percent(v.heldin_gain_high),
          percent(v.discretization_heldin_gain), percent(v.gain), percent(v.gain_low), percent(v.gain_high)));
    else
      d.lines.push_back(fmt::format("cause: {}. Modelling it removes {} of the held-out residual (90 % interval {} .. {}; "
                                    "a placebo of as many parameters: {})",
                                    v.name, percent(v.gain), percent(v.gain_low), percent(v.gain_high),
                                    percent(v.placebo_gain)));
    std::string extras;
    for (size_t i = 0; i < m.names.size(); ++i)
      if (!base_values.count(m.names[i]))
        extras += fmt::format("{}{} = {}", extras.empty() ? "" : ", ", m.names[i], with_unit(m.names[i], m.values[Eigen::Index(i)]));
    if (!extras.empty()) d.lines.push_back("fitted: " + extras);
    if (const ExtensionRow* row = find_extension(m.name); row && row->fit == ExtensionRow::Fit::Measurement) {
      std::string corrected;
      for (size_t i = 0; i < m.names.size(); ++i)
        if (base_values.count(m.names[i]))
          corrected += fmt::format("{}{} = {}", corrected.empty() ? "" : ", ", m.names[i],
                                   with_unit(m.names[i], m.values[Eigen::Index(i)]));
      d.lines.push_back(fmt::format("{}; with it corrected: {}", row->tell(m.values[m.values.size() - 1]), corrected));
    }
    if (!m.proposal.empty()) d.lines.push_back("proposed from the data: " + m.proposal);
    if (!d.simpler_than.empty()) d.lines.push_back(d.simpler_than);
    if (!d.unjudged.empty())
      d.lines.push_back(fmt::format("{} also passed, fitted to the frames as recorded: correct the recording and "
                                    "diagnose again to judge {}",
                                    fmt::join(d.unjudged, ", "), d.unjudged.size() == 1 ? "it" : "them"));
  }
  const Diagnosis::Control* finest = nullptr;  // the control with the largest gain
  for (const Diagnosis::Control& k : d.controls)
    if (!k.fit.failed && (!finest || k.gain > finest->gain)) finest = &k;
  for (size_t i = 0; i < d.verdicts.size() && finest; ++i) {
    const CandidateVerdict& v = d.verdicts[i];
    if (v.passes || !v.implausible.empty() || v.gain < o.min_gain || v.gain_low <= v.placebo_gain + o.margin) continue;
    if (!std::isnan(v.control_gain))
      d.lines.push_back(fmt::format("{} would remove {} of the held-out residual but is not named: beyond the base "
                                    "model with {}, it removes {}",
                                    v.name, percent(v.gain), finest->fit.proposal, percent(v.control_gain)));
    else
      d.lines.push_back(fmt::format("{} would remove {} of the held-out residual but is not named: the base model with "
                                    "{} removes {}, so the model's own discretization can explain as much",
                                    v.name, percent(v.gain), finest->fit.proposal, percent(finest->gain)));
  }
  for (const Diagnosis::Control& k : d.controls)
    if (!k.fit.failed && k.gain >= o.min_gain)
      d.lines.push_back(fmt::format("discretization: the base model with {} removes {} of the held-out residual; it "
                                    "fits closer there (fitted: {})",
                                    k.fit.proposal, percent(k.gain), values_text(k.fit)));
  for (size_t i = 0; i < d.verdicts.size(); ++i)
    if (!d.verdicts[i].implausible.empty() && d.verdicts[i].gain >= o.min_gain)
      d.lines.push_back(fmt::format("{} would remove {} of the held-out residual but is not named: its fit needs {}",
                                    d.verdicts[i].name, percent(d.verdicts[i].gain), d.verdicts[i].implausible[0]));
  for (const auto& [a, b] : d.confounded) d.lines.push_back(confounded_line(a, b, candidate_named(d, a), candidate_named(d, b)));
  for (const auto& [candidate, what] : d.undecided)
    d.lines.push_back(fmt::format("{}; these data cannot tell which ({} fits the held-in and the held-out frames as well "
                                  "as the base model)",
                                  what, candidate));
  for (const auto& [a, b, r] : d.indistinguishable)
    if (owner(a) == d.cause || owner(b) == d.cause)
      d.lines.push_back(fmt::format("{} and {}: correlation {:+.3f} at the fit (Gauss-Newton): the data fix a "
                                    "combination of them, not each",
                                    a, b, r));
  std::string spans;
  for (const ParameterSlice& s : d.slices)
    spans += fmt::format("{}{} {} .. {} (fitted {})", spans.empty() ? "" : ", ", s.name, with_unit(s.name, s.low),
                         with_unit(s.name, s.high), with_unit(s.name, s.fitted));
  if (!spans.empty())
    d.lines.push_back(fmt::format("the held-in cost stays within {} of the fit's over {}", percent(kSliceTolerance), spans));
  for (const ParameterSlice& s : d.slices) {
    if (!s.open_low && !s.open_high) continue;
    const std::string span = fmt::format("from {} to {}", with_unit(s.name, s.low), with_unit(s.name, s.high));
    const std::string within = fmt::format("the held-in cost stays within {} of the fit's", percent(kSliceTolerance));
    if (s.open_low && s.open_high)
      d.lines.push_back(fmt::format("{}: not fixed by the data: {} (the whole range probed) {}", s.name, span, within));
    else
      d.lines.push_back(fmt::format("{}: the data fix only {} bound, {} {}: {} ({} the end of the range probed: its "
                                    "plausible range, at most a factor {:g} from the fit) {}; the fitted {} is one "
                                    "value of that plateau",
                                    s.name, s.open_high ? "a lower" : "an upper", s.open_high ? ">=" : "<=",
                                    with_unit(s.name, s.open_high ? s.low : s.high), span,
                                    s.open_high ? with_unit(s.name, s.high) : with_unit(s.name, s.low),
                                    kSliceFactor, within, with_unit(s.name, s.fitted)));
  }
  if (!named.empty() && !d.identifiability.failure.empty())
    d.lines.push_back("identifiability not assessed: " + d.identifiability.failure);
  if (d.confounded.empty() && d.identifiability.correlation.rows() >= 2) {
    // The cause's parameter with the largest correlation with another, when none is near +-1.
    const Eigen::MatrixXd& c = d.identifiability.correlation;
    const std::vector<std::string>& n = d.identifiability.names;
    Eigen::Index bi = -1, bj = -1;
    for (Eigen::Index i = 0; i < c.rows(); ++i)
      for (Eigen::Index j = i + 1; j < c.cols(); ++j)
        if ((owner(n[size_t(i)]) == d.cause || owner(n[size_t(j)]) == d.cause) &&
            (bi < 0 || std::abs(c(i, j)) > std::abs(c(bi, bj))))
          bi = i, bj = j;
    if (bi >= 0)
      d.lines.push_back(fmt::format("identifiability (Gauss-Newton, at the fit): nothing trades off against {} (its "
                                    "largest correlation: {} and {}, {:+.2f})",
                                    d.cause, n[size_t(bi)], n[size_t(bj)], c(bi, bj)));
  }
  std::string flat;
  for (const std::string& f : d.identifiability.flat)
    if (owner(f) == d.cause || base_values.count(f)) flat += (flat.empty() ? "" : ", ") + f;
  if (!flat.empty()) d.lines.push_back("the held-in frames do not depend on " + flat + " at the fit: not determined");
  for (size_t i = 0; i < d.candidates.size(); ++i) {
    const FittedModel& m = d.candidates[i];
    if (m.failed) continue;
    for (const auto& [name, before, after] : moved_base(d.base, m)) {
      const std::string w = fmt::format("{} moves from {} to {} ({:+.0f} %) once {} is modelled", name,
                                        with_unit(name, before), with_unit(name, after), 100 * (after / before - 1), m.name);
      d.verdicts[i].warnings.push_back(w);
      if (d.cause == m.name) d.lines.push_back(w);
    }
  }
  std::string limited;
  int models = 1, converged = stopped_converged(d.base.stop_reason);
  if (!converged) limited = "base";
  std::vector<const FittedModel*> fitted;
  for (const FittedModel& m : d.candidates) fitted.push_back(&m);
  for (const Diagnosis::Control& k : d.controls) fitted.push_back(&k.fit);
  for (const FittedModel* f : fitted)
    if (const FittedModel& m = *f; !m.failed) {
      ++models;
      if (stopped_converged(m.stop_reason)) ++converged;
      else limited += (limited.empty() ? "" : ", ") + m.name;
    }
  if (!limited.empty())
    d.lines.push_back(fmt::format("convergence: {} of {} fits converged; {} stopped at the iteration limit ({} "
                                  "iterations): raise --iterations for a firmer verdict",
                                  converged, models, limited, o.iterations));
}

}  // namespace

Diagnosis diagnose(const std::string& scene_path, const std::vector<std::string>& overrides,
                   const std::string& observations, double phi_max, const DiagnosisOptions& o,
                   const DiagnosisProgress& progress) {
  const auto t0 = std::chrono::steady_clock::now();
  std::mutex saying;  // the fits of step 3 say what they do from their threads
  auto say = [&](const std::string& s) {
    std::lock_guard<std::mutex> lock(saying);
    if (progress) progress(s);
  };
  Diagnosis d;
  Scene scene;
  DiagnosisContext c = prepare(d, scene_path, overrides, observations, phi_max, o, &scene);
  // Within the fits, a line at most every kRoundLines seconds: a diagnosis on the CPU runs for minutes.
  auto last_round = std::chrono::steady_clock::now();
  c.round_progress = [&](const std::string& s) {
    std::lock_guard<std::mutex> lock(saying);
    if (!progress || seconds_since(last_round) < kRoundLines) return;
    last_round = std::chrono::steady_clock::now();
    progress(s);
  };

  std::vector<std::map<std::string, double>> base_starts;
  Problem shared_problem;
  std::map<std::string, std::string> skipped;
  std::map<std::string, FittedModel> shared_fits = fit_shared(d, c, scene, base_starts, shared_problem, skipped, say);

  // The likely cause's refits on the controls' discretizations in step 3's queue, where its
  // fits run side by side.
  const std::string likely = o.discretization_controls && fit_threads(c).size() > 1
                                 ? likely_cause(d.base, d.heldin_frames, shared_fits, o)
                                 : std::string();
  const std::vector<ControlRefit> early =
      likely.empty() ? std::vector<ControlRefit>{} : control_refits(shared_fits.at(likely), scene, discretization_controls());
  std::vector<DiscretizationCheck> early_checks(early.size());
  std::vector<std::function<void(const std::string&)>> after;
  std::vector<double> after_weights;
  for (size_t k = 0; k < early.size(); ++k) {
    after_weights.push_back(kEarlyRefitShare * schedule_weight(early[k].control));
    after.push_back([&, k](const std::string& device) {
      say("fitting " + early[k].spec.name + " ahead (the likely cause)");
      early_checks[k] = refit_on_control(early[k], shared_fits.at(likely), c, d.base.problem.phi_max, device);
      say(early[k].spec.name + " done");
    });
  }
  // Steps 2 and 3 at once on the GPU where one process runs alone (MPI needs its calls on this
  // thread; on the CPU the two would share the cores): the score test only orders the verdicts.
  std::map<std::string, FittedModel> own_fits;
  std::exception_ptr own_failure;
  auto fit_own_candidates = [&] {
    try {
      own_fits = fit_own_all(d, c, scene, o.candidates, shared_fits, base_starts, skipped, say, after, after_weights);
    } catch (...) {
      own_failure = std::current_exception();
    }
  };
  std::thread own_thread;
  if (ranks::count() == 1 && runs_on_gpu(c.options.device))
    own_thread = std::thread(fit_own_candidates);
  else
    fit_own_candidates();
  say("the score test");
  std::map<std::string, double> score;
  try {
    score = score_test(d.base, c);
  } catch (const std::exception& e) {
    d.lines.push_back(std::string("the score test failed: ") + e.what());
  }
  if (own_thread.joinable()) own_thread.join();
  if (own_failure) std::rethrow_exception(own_failure);
  if (o.discretization_controls)
    for (const std::string& control : discretization_controls()) {
      Diagnosis::Control k;
      if (const auto f = own_fits.find(control); f != own_fits.end()) {
        k.fit = std::move(f->second);
        own_fits.erase(f);
      }
      k.fit.name = control;
      if (const auto w = skipped.find(control); w != skipped.end()) {
        k.fit.failed = true;
        k.fit.failure = w->second;
        skipped.erase(w);
      }
      d.controls.push_back(std::move(k));
    }
  std::vector<std::string> order = o.candidates;  // by score, the untestable ones last
  std::stable_sort(order.begin(), order.end(), [&](const std::string& a, const std::string& b) {
    const double sa = score.count(a) ? score.at(a) : -1, sb = score.count(b) ? score.at(b) : -1;
    return sa > sb;
  });

  for (const std::string& name : order) {
    CandidateVerdict v;
    v.name = name;
    if (score.count(name)) v.score = score.at(name);
    FittedModel m;
    if (const auto f = shared_fits.find(name); f != shared_fits.end()) m = f->second;
    if (const auto f = own_fits.find(name); f != own_fits.end()) m = std::move(f->second);
    m.name = name;
    if (skipped.count(name)) {
      m.failed = true;
      m.failure = skipped.at(name);
      v.warnings.push_back("not fitted: " + m.failure);
    } else if (m.failed) {
      v.warnings.push_back("the fit failed: " + m.failure);
    }
    if (!m.note.empty()) v.warnings.push_back(m.note);
    d.candidates.push_back(std::move(m));
    d.verdicts.push_back(v);
  }

  std::vector<size_t> named;
  std::string slices_failure;
  say("judging the candidates");
  judge(d, c, named);
  find_undecided(d, c);
  if (!named.empty()) {
    const FittedModel& m = d.candidates[named[0]];
    say("identifiability at the " + m.name + " fit");
    try {
      identifiability_at(d, m, shared_fits.count(m.name) ? &shared_problem : nullptr, c);
    } catch (const std::exception& e) {
      d.identifiability.failure = e.what();
    }
    say("the held-in cost along the " + m.name + " fit's parameters");
    try {
      slices_at(d, m, shared_fits.count(m.name) ? &shared_problem : nullptr, c);
    } catch (const std::exception& e) {
      slices_failure = e.what();
    }
    if (m.name == d.cause && m.name == likely) {
      d.cause_on_controls = checks_of(controls_that_ran(d), early_checks);
    } else if (m.name == d.cause) {
      say("the " + m.name + " fit on the controls' discretizations");
      d.cause_on_controls = refit_on_controls(m, controls_that_ran(d), c, scene, d.base.problem.phi_max);
    }
  }
  tell(d, o, named);
  if (!slices_failure.empty()) d.lines.push_back("the held-in cost along the cause's parameters failed: " + slices_failure);
  for (const DiscretizationCheck& g : d.cause_on_controls) d.lines.push_back(control_check_line(g, d.cause));
  d.seconds = seconds_since(t0);
  return d;
}

const FittedModel* candidate_named(const Diagnosis& d, const std::string& name) {
  const auto it = std::find_if(d.candidates.begin(), d.candidates.end(), [&](const FittedModel& m) { return m.name == name; });
  return it == d.candidates.end() ? nullptr : &*it;
}

}  // namespace ssc
