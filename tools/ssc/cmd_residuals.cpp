// `ssc residuals SCENE --observations DIR --params result.json --out OUT`: where the fitted
// simulation disagrees with the observations (models/diagnosis/residuals.h): residuals.csv
// (one row per observed point), residuals.json (by frame, phase, region, direction),
// residual_vs_time.svg and report.html (residual images per camera, on the rest shape), and
// how far the residual is above the depth noise (models/diagnosis/goodness_of_fit.h).
#include <fmt/format.h>

#include <fstream>
#include <nlohmann/json.hpp>

#include "models/diagnosis/goodness_of_fit.h"
#include "models/diagnosis/report_data.h"
#include "models/diagnosis/report_html.h"
#include "models/diagnosis/residuals.h"
#include "models/io/folder_hash.h"
#include "models/io/output_dir.h"
#include "models/io/run_record.h"
#include "models/io/svg_plot.h"
#include "models/io/text_file.h"
#include "models/sim/compute_device.h"
#include "models/sim/problem.h"
#include "runtime/errors.h"
#include "runtime/cuda_runtime.h"
#include "tools/ssc/commands.h"
#include "tools/ssc/device_option.h"
#include "tools/ssc/fitted_parameters.h"
#include "tools/ssc/progress.h"

namespace ssc {
namespace {

// The RMS residual per frame and the noise it is compared with, contact events as vertical lines.
void write_residual_plot(const std::string& path, const Residuals& r, const GoodnessOfFit& fit) {
  PlotPanel p{"RMS residual of the matched points per frame (lines: contacts begin)", "time [s]", "residual [mm]",
              false, false, true, {}, {}};
  PlotSeries s{"fit", {}, {}, "#1f77b4", 2.0, true};
  for (const FrameResiduals& f : r.frames) s.x.push_back(f.time), s.y.push_back(1e3 * f.rms);
  PlotSeries noise{"depth noise", {}, {}, "#999999", 1.5, false};
  for (size_t f = 0; f < fit.frames.size(); ++f)
    if (fit.frames[f].noise_m > 0) noise.x.push_back(fit.frame_times_s[f]), noise.y.push_back(1e3 * fit.frames[f].noise_m);
  if (!noise.x.empty()) p.series.push_back(noise);
  p.series.push_back(s);
  p.vertical_lines = r.contact_times;
  write_svg_plot(path, {p});
}

}  // namespace

Command register_residuals(CLI::App& app) {
  struct Options {
    std::string scene, observations, params, out;
    std::vector<std::string> overrides;
    double phi_max = 0;
    std::string device = "auto";
    ProgressMode progress = ProgressMode::Auto;
  };
  auto o = std::make_shared<Options>();
  CLI::App* sub = app.add_subcommand("residuals", "Where a fitted simulation disagrees with the observations");
  sub->add_option("scene", o->scene, "Scene file")->required();
  sub->add_option("--observations", o->observations, "Observation folder")->required();
  sub->add_option("--params", o->params, "result.json of ssc reconstruct (its \"set\" list is applied)");
  sub->add_option("--out", o->out, "Output folder (replaced atomically)")->required();
  sub->add_option("--set", o->overrides, "Override a scene key: dotted.key=JSON, repeatable");
  sub->add_option("--phi-max", o->phi_max, "Cost threshold in metres");
  add_device_option(sub, &o->device);
  add_progress_options(sub, &o->progress);
  return [o] {
    Progress progress("residuals", 0, o->progress);
    const std::string device = choose_device(o->device);
    const FittedParameters fitted = read_fitted_parameters(o->params);
    std::vector<std::string> overrides = o->overrides;
    overrides.insert(overrides.end(), fitted.set.begin(), fitted.set.end());
    const Problem problem = load_problem(o->scene, overrides, o->observations, o->phi_max, fitted.names);
    const nlohmann::json observations = folder_fingerprint(o->observations);
    if (const std::string differs =
            check_fitted_on(fitted, o->params, problem.scene, o->scene, observations.value("fnv1a64", ""));
        !differs.empty())
      warn("params", differs);
    OutputDir out(o->out, {o->scene, o->observations, o->params, problem.scene.object.path});
    out.manifest()["scene"] = {{"file", o->scene}, {"resolved", problem.scene.resolved}};
    out.manifest()["observations"] = observations;
    if (!o->params.empty()) out.manifest()["params"] = {{"file", o->params}, {"set", fitted.set}};
    out.manifest()["device"] = describe_device(device);
    size_t points = 0;
    for (const ObservedFrame& f : problem.frames) points += f.points.size();
    progress.stage(fmt::format("simulating {} steps and measuring {} observed points of {} frames", problem.scene.time.steps,
                               points, problem.frames.size()));
    const Residuals r = compute_residuals(problem, PhysicalParameters::from_scene(problem.scene), device);
    progress.stage("writing the tables, the plot and report.html");
    nlohmann::json summary = residual_summary(r);
    const GoodnessOfFit fit = goodness_of_fit(problem, r);
    warn_if_above_noise(fit);
    summary["goodness_of_fit"] = goodness_json(fit);
    write_text_file(out.file("residuals.csv"), residuals_csv(r));
    write_text_file(out.file("residuals.json"), summary.dump(2) + "\n");
    write_residual_plot(out.file("residual_vs_time.svg"), r, fit);
    nlohmann::json data;
    data["title"] = "ssc residuals: " + o->scene;
    data["summary_lines"] = {goodness_line(fit)};
    if (fit.above_noise) data["summary_lines"].push_back("Warning: " + fit.warning);
    data["provenance"] = {{"scene", o->scene}, {"observations", o->observations}, {"params", o->params}};
    add_residual_report_data(data, problem, r, nullptr);
    write_report_html(out.file("report.html"), data);
    out.commit();
    const nlohmann::json& all = summary["all"];
    std::printf("%d of %d observed points matched (%.1f %%); RMS residual %.3g mm\n", all["matched"].get<int>(),
                all["points"].get<int>(), 100 * all["matched_fraction"].get<double>(), 1e3 * all["rms_m"].get<double>());
    for (const auto& [phase, a] : summary["by_phase"].items())
      std::printf("  %-22s %6d points, %5.1f %% matched, RMS %.3g mm\n", phase.c_str(), a["points"].get<int>(),
                  100 * a["matched_fraction"].get<double>(), 1e3 * a["rms_m"].get<double>());
    std::printf("%s\n", goodness_line(fit).c_str());
    std::printf("wrote %s: residuals.csv, residuals.json, residual_vs_time.svg, report.html\n", o->out.c_str());
    return 0;
  };
}

}  // namespace ssc
