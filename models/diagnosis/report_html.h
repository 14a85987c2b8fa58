// The `ssc diagnose` report as one self-contained HTML page: plain CSS, no scripts, no
// external files; every figure is inline SVG (bar chart of the candidates' gains, residual
// over time, residual images and the residual on the rest shape in a diverging colour map).
//
// The input is a JSON object; only "title" is required. Every other key may be missing or
// null, any number may be null (no value), arrays may be empty: what is there is rendered,
// a section with no data is left out. The keys:
//   title, cause, summary_lines[], provenance{scene, observations, command, version, device, date}
//   candidates[]{name, extra_parameters{}, heldout_before, heldout_after, gain, gain_low, gain_high,
//                placebo_gain, score, passes, base_before{}, base_after{}, warnings[]}
//   confounded[][name, name], confounded_base[]{models[name, name], parameter, values[2]},
//   parameters{units{}, base{}, winner{}}
//   residual_vs_time{time[], before_mm[], after_mm[], heldout_from, contact_times[]}
//   residual_images[]{camera, frame, time, width, height, before_mm[W*H], after_mm[W*H]}  (row-major)
//   rest_shape{points[][x, y, z], before_mm[], after_mm[]}
#pragma once
#include <nlohmann/json.hpp>
#include <string>

namespace ssc {

// The whole page, starting with <!DOCTYPE html>.
std::string render_report_html(const nlohmann::json& data);

// Renders and writes the page atomically (temp file + rename); InputError naming the file.
void write_report_html(const std::string& path, const nlohmann::json& data);

}  // namespace ssc
