// The diagnosis report page (see report_html.h).
//
// Design: each section is a function from the report JSON to an HTML fragment, empty when
// its data is missing, so that a partial report still renders. The JSON is read only through
// the accessors at the top (member, number_at, text_at, numbers_at), which turn anything that
// is not what they expect into "no value" (NaN, "", an empty list); nothing below them
// can throw on odd input. Figures are inline SVG: the residual-over-time plot comes from
// models/io/svg_plot.h, the bar chart, the images and the point projections are drawn here.
// Residual images and rest-shape points use one diverging colour map, quantised so that
// neighbouring pixels of about the same value merge into one <rect>.
#include "models/diagnosis/report_html.h"

#include <fmt/format.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <limits>
#include <vector>

#include "models/io/svg_plot.h"
#include "models/io/text_file.h"
#include "runtime/errors.h"

namespace ssc {
namespace {

using nlohmann::json;
constexpr double kNoValue = std::numeric_limits<double>::quiet_NaN();
const char* const kNoValueText = "\u2013";  // en dash

// ---- reading the JSON without throwing -----------------------------------------------------

const json& member(const json& object, const char* key) {
  static const json null_value;
  if (!object.is_object()) return null_value;
  const auto it = object.find(key);
  return it == object.end() ? null_value : *it;
}

double as_number(const json& value) { return value.is_number() ? value.get<double>() : kNoValue; }
double number_at(const json& object, const char* key) { return as_number(member(object, key)); }

std::string text_at(const json& object, const char* key) {
  const json& value = member(object, key);
  return value.is_string() ? value.get<std::string>() : "";
}

std::vector<double> numbers_at(const json& object, const char* key) {
  std::vector<double> out;
  const json& value = member(object, key);
  if (value.is_array())
    for (const json& v : value) out.push_back(as_number(v));
  return out;
}

bool has_items(const json& value) { return (value.is_array() || value.is_object()) && !value.empty(); }

// ---- text ----------------------------------------------------------------------------------

std::string escape_html(const std::string& text) {
  std::string out;
  out.reserve(text.size());
  for (char c : text) switch (c) {
      case '&': out += "&amp;"; break;
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '"': out += "&quot;"; break;
      case '\'': out += "&#39;"; break;
      default: out += c;
    }
  return out;
}

std::string format_number(double v) { return std::isfinite(v) ? fmt::format("{:.4g}", v) : kNoValueText; }
std::string format_percent(double fraction) { return std::isfinite(fraction) ? fmt::format("{:.4g} %", 100 * fraction) : kNoValueText; }

// Any JSON value as escaped text: numbers with format_number, null as a dash.
std::string format_value(const json& value) {
  if (value.is_number()) return format_number(value.get<double>());
  if (value.is_string()) return escape_html(value.get<std::string>());
  if (value.is_boolean()) return value.get<bool>() ? "yes" : "no";
  if (value.is_null()) return kNoValueText;
  return escape_html(value.dump(-1, ' ', false, json::error_handler_t::replace));
}

// "key = value" lines of a JSON object.
std::string format_assignments(const json& object) {
  std::string out;
  if (object.is_object())
    for (const auto& [key, value] : object.items()) out += fmt::format("{}{} = {}", out.empty() ? "" : "<br>", escape_html(key), format_value(value));
  return out.empty() ? kNoValueText : out;
}

// "key: before → after" lines over the keys of both objects.
std::string format_changes(const json& before, const json& after) {
  std::vector<std::string> keys;
  for (const json* object : {&before, &after})
    if (object->is_object())
      for (const auto& item : object->items())
        if (std::find(keys.begin(), keys.end(), item.key()) == keys.end()) keys.push_back(item.key());
  std::string out;
  for (const std::string& key : keys)
    out += fmt::format("{}{}: {} \u2192 {}", out.empty() ? "" : "<br>", escape_html(key), format_value(member(before, key.c_str())),
                       format_value(member(after, key.c_str())));
  return out.empty() ? kNoValueText : out;
}

std::string section(const std::string& heading, const std::string& body) {
  return body.empty() ? "" : fmt::format("<section>\n<h2>{}</h2>\n{}</section>\n", escape_html(heading), body);
}

// ---- the diverging colour map --------------------------------------------------------------

constexpr int kColourSteps = 16;  // quantisation levels on each side of 0
const char* const kMissingColour = "#d0d0d0";
struct Rgb {
  double r, g, b;
};
// From 0 to 1 on the positive (red) side; the negative side mirrors it in blue.
const std::array<Rgb, 4> kRedStops = {{{255, 255, 255}, {253, 219, 199}, {239, 138, 98}, {178, 24, 43}}};
const std::array<Rgb, 4> kBlueStops = {{{255, 255, 255}, {209, 229, 240}, {103, 169, 207}, {33, 102, 172}}};

// Blue for negative, white for 0, red for positive; |value| >= range saturates; grey for no value.
std::string diverging_colour(double value, double range) {
  if (!std::isfinite(value)) return kMissingColour;
  const double level = std::round(std::clamp(value / range, -1.0, 1.0) * kColourSteps) / kColourSteps;
  const auto& stops = level < 0 ? kBlueStops : kRedStops;
  const double position = std::abs(level) * (stops.size() - 1);
  const size_t i = std::min(size_t(position), stops.size() - 2);
  const double t = position - double(i);
  auto channel = [&](double a, double b) { return int(std::lround(a + t * (b - a))); };
  return fmt::format("#{:02x}{:02x}{:02x}", channel(stops[i].r, stops[i + 1].r), channel(stops[i].g, stops[i + 1].g),
                     channel(stops[i].b, stops[i + 1].b));
}

// The symmetric colour range: the 98th percentile of |value| over the finite values, so that a
// few outliers do not wash the rest out; 1 when there is nothing to go by.
double robust_range(const std::vector<const std::vector<double>*>& lists) {
  std::vector<double> magnitudes;
  for (const auto* list : lists)
    for (double v : *list)
      if (std::isfinite(v)) magnitudes.push_back(std::abs(v));
  if (magnitudes.empty()) return 1;
  const auto nth = magnitudes.begin() + std::ptrdiff_t(0.98 * double(magnitudes.size() - 1));
  std::nth_element(magnitudes.begin(), nth, magnitudes.end());
  if (*nth > 0) return *nth;
  const double largest = *std::max_element(magnitudes.begin(), magnitudes.end());
  return largest > 0 ? largest : 1;
}

// The colour map from -range to range in mm, with a swatch of the grey that stands for missing_label.
std::string colour_bar_svg(double range, const std::string& missing_label) {
  const double x0 = 20, bar_width = 320, y0 = 4, bar_height = 14;
  const int levels = 2 * kColourSteps + 1;
  std::string svg =
      "<svg xmlns=\"http://www.w3.org/2000/svg\" class=\"colorbar\" width=\"560\" height=\"58\" font-size=\"12\" "
      "shape-rendering=\"crispEdges\">\n";
  for (int i = 0; i < levels; ++i) {
    const double value = range * (double(i - kColourSteps) / kColourSteps);
    svg += fmt::format("<rect x=\"{:.2f}\" y=\"{}\" width=\"{:.2f}\" height=\"{}\" fill=\"{}\"/>\n", x0 + bar_width * i / levels, y0,
                       bar_width / levels + 0.5, bar_height, diverging_colour(value, range));
  }
  svg += fmt::format("<rect x=\"{}\" y=\"{}\" width=\"{}\" height=\"{}\" fill=\"none\" stroke=\"#555\"/>\n", x0, y0, bar_width, bar_height);
  for (double tick : plot_ticks(-range, range)) {
    const double x = x0 + bar_width * (tick / range + 1) / 2;
    svg += fmt::format("<line x1=\"{0:.1f}\" y1=\"{1}\" x2=\"{0:.1f}\" y2=\"{2}\" stroke=\"#555\"/>", x, y0 + bar_height, y0 + bar_height + 4);
    svg += fmt::format("<text x=\"{:.1f}\" y=\"{}\" text-anchor=\"middle\">{:.3g}</text>\n", x, y0 + bar_height + 16, tick);
  }
  svg += fmt::format("<text x=\"{}\" y=\"{}\" text-anchor=\"middle\">residual [mm] (values beyond \u00b1{:.3g} drawn as \u00b1{:.3g})</text>\n",
                     x0 + bar_width / 2, y0 + bar_height + 34, range, range);
  svg += fmt::format("<rect x=\"{}\" y=\"{}\" width=\"14\" height=\"14\" fill=\"{}\" stroke=\"#555\"/><text x=\"{}\" y=\"{}\">{}</text>\n",
                     x0 + bar_width + 30, y0, kMissingColour, x0 + bar_width + 50, y0 + 12, missing_label);
  return svg + "</svg>\n";
}

// ---- 1. title, cause, summary, provenance --------------------------------------------------

std::string header_html(const json& data, const std::string& title) {
  std::string html = fmt::format("<h1>{}</h1>\n", escape_html(title));
  const std::string cause = text_at(data, "cause");
  if (cause == "none")
    html += "<p class=\"cause none\">No candidate explains the residual better than chance (none)</p>\n";
  else if (!cause.empty())
    html += fmt::format("<p class=\"cause\">Most likely missing effect: {}</p>\n", escape_html(cause));
  const json& lines = member(data, "summary_lines");
  if (has_items(lines) && lines.is_array()) {
    html += "<ul class=\"summary\">\n";
    for (const json& line : lines) html += fmt::format("<li>{}</li>\n", format_value(line));
    html += "</ul>\n";
  }
  const json& provenance = member(data, "provenance");
  if (has_items(provenance) && provenance.is_object()) {
    html += "<table class=\"provenance\">\n";
    static const std::vector<std::string> first = {"scene", "observations", "command", "version", "device", "date"};
    for (const std::string& key : first)
      if (provenance.contains(key)) html += fmt::format("<tr><th>{}</th><td>{}</td></tr>\n", key, format_value(member(provenance, key.c_str())));
    for (const auto& [key, value] : provenance.items())
      if (std::find(first.begin(), first.end(), key) == first.end())
        html += fmt::format("<tr><th>{}</th><td>{}</td></tr>\n", escape_html(key), format_value(value));
    html += "</table>\n";
  }
  return html;
}

// ---- 2. candidates -------------------------------------------------------------------------

// Horizontal bars of the gains (as % of the held-out residual) with their 90 % intervals, the
// placebo gains as diamonds, and a line at 0; passing candidates in green.
std::string gain_chart_svg(const json& candidates) {
  // The names are right-aligned before the bars: the column fits the longest in bold (about
  // 8.5 px a character at 13 px), so that none is cut at the left edge.
  size_t longest = 0;
  for (const json& c : candidates) longest = std::max(longest, text_at(c, "name").size());
  const double label_width = std::max(170.0, 8.5 * double(longest) + 20), plot_width = 640, row_height = 30, top = 10;
  const double height = top + row_height * double(candidates.size()) + 76;
  double lo = 0, hi = 0;
  for (const json& c : candidates)
    for (const char* key : {"gain", "gain_low", "gain_high", "placebo_gain"}) {
      const double v = number_at(c, key);
      if (std::isfinite(v)) lo = std::min(lo, v), hi = std::max(hi, v);
    }
  if (hi - lo < 0.1) hi = lo + 0.1;
  const double pad = 0.04 * (hi - lo);
  lo -= pad, hi += pad;
  const double x0 = label_width, x1 = label_width + plot_width, y_axis = top + row_height * double(candidates.size());
  auto x_of = [&](double v) { return x0 + (v - lo) / (hi - lo) * plot_width; };

  std::string svg = fmt::format(
      "<svg xmlns=\"http://www.w3.org/2000/svg\" class=\"gain-chart\" width=\"{}\" height=\"{}\" font-size=\"13\">\n"
      "<rect x=\"{}\" y=\"{}\" width=\"{}\" height=\"{}\" fill=\"#fafafa\" stroke=\"#999\"/>\n",
      x1 + 20, height, x0, top, plot_width, y_axis - top);
  for (double t : plot_ticks(lo, hi))
    svg += fmt::format("<line x1=\"{0:.1f}\" y1=\"{1}\" x2=\"{0:.1f}\" y2=\"{2}\" stroke=\"#e4e4e4\"/><text x=\"{0:.1f}\" y=\"{3}\" text-anchor=\"middle\">{4:.4g}</text>\n",
                       x_of(t), top, y_axis, y_axis + 16, 100 * t);
  svg += fmt::format("<text x=\"{}\" y=\"{}\" text-anchor=\"middle\">gain: share of the held-out residual explained [%]</text>\n",
                     (x0 + x1) / 2, y_axis + 34);
  for (size_t i = 0; i < candidates.size(); ++i) {
    const json& c = candidates[i];
    const double yc = top + row_height * (double(i) + 0.5);
    const bool passes = member(c, "passes").is_boolean() && member(c, "passes").get<bool>();
    const std::string name = text_at(c, "name").empty() ? fmt::format("candidate {}", i + 1) : text_at(c, "name");
    svg += fmt::format("<text x=\"{}\" y=\"{:.1f}\" text-anchor=\"end\"{}>{}</text>\n", x0 - 8, yc + 4,
                       passes ? " font-weight=\"bold\"" : "", escape_html(name));
    const double gain = number_at(c, "gain"), low = number_at(c, "gain_low"), high = number_at(c, "gain_high"), placebo = number_at(c, "placebo_gain");
    if (std::isfinite(gain)) {
      const double a = x_of(std::min(0.0, gain)), b = x_of(std::max(0.0, gain));
      svg += fmt::format("<rect x=\"{:.1f}\" y=\"{:.1f}\" width=\"{:.1f}\" height=\"14\" fill=\"{}\"/>\n", a, yc - 7, std::max(b - a, 1.0),
                         passes ? "#2f9e44" : "#adb5bd");
    }
    if (std::isfinite(low) && std::isfinite(high))
      svg += fmt::format("<path d=\"M{0:.1f} {1:.1f}V{2:.1f}M{0:.1f} {3:.1f}H{4:.1f}M{4:.1f} {1:.1f}V{2:.1f}\" stroke=\"#222\" stroke-width=\"1.5\" fill=\"none\"/>\n",
                         x_of(low), yc - 6, yc + 6, yc, x_of(high));
    if (std::isfinite(placebo)) {
      const double px = x_of(placebo);
      svg += fmt::format("<path d=\"M{0:.1f} {1:.1f}L{2:.1f} {3:.1f}L{0:.1f} {4:.1f}L{5:.1f} {3:.1f}Z\" fill=\"#f59f00\" stroke=\"#7a4f00\"/>\n",
                         px, yc - 6, px + 6, yc, yc + 6, px - 6);
    }
  }
  svg += fmt::format("<line x1=\"{0:.1f}\" y1=\"{1}\" x2=\"{0:.1f}\" y2=\"{2}\" stroke=\"black\" stroke-width=\"1.5\"/>\n", x_of(0), top, y_axis);
  const double ly = y_axis + 56;
  svg += fmt::format(
      "<rect x=\"{0}\" y=\"{1}\" width=\"14\" height=\"10\" fill=\"#2f9e44\"/><text x=\"{2}\" y=\"{3}\">passes</text>\n"
      "<rect x=\"{4}\" y=\"{1}\" width=\"14\" height=\"10\" fill=\"#adb5bd\"/><text x=\"{5}\" y=\"{3}\">does not pass</text>\n"
      "<path d=\"M{6} {1}v10M{6} {7}h24M{8} {1}v10\" stroke=\"#222\" stroke-width=\"1.5\"/><text x=\"{9}\" y=\"{3}\">90 % interval</text>\n"
      "<path d=\"M{10} {11}l6 6l-6 6l-6 -6Z\" fill=\"#f59f00\" stroke=\"#7a4f00\"/><text x=\"{12}\" y=\"{3}\">placebo gain</text>\n",
      x0, ly - 9, x0 + 20, ly, x0 + 90, x0 + 110, x0 + 230, ly - 4, x0 + 254, x0 + 262, x0 + 380, ly - 10, x0 + 392);
  return svg + "</svg>\n";
}

std::string candidates_html(const json& data) {
  const json& candidates = member(data, "candidates");
  std::string html;
  if (has_items(candidates) && candidates.is_array()) {
    html += "<figure>" + gain_chart_svg(candidates) + "</figure>\n";
    html += "<table class=\"candidates\">\n<tr><th>candidate</th><th>extra parameters</th><th>held-out cost before \u2192 after [m\u00b2]</th>"
            "<th>gain [90 % interval]</th><th>placebo gain</th><th>score</th><th>base parameters before \u2192 after</th><th>warnings</th></tr>\n";
    for (const json& c : candidates) {
      const bool passes = member(c, "passes").is_boolean() && member(c, "passes").get<bool>();
      std::string warnings;
      const json& list = member(c, "warnings");
      if (list.is_array())
        for (const json& w : list) warnings += (warnings.empty() ? "" : "<br>") + format_value(w);
      html += fmt::format(
          "<tr{}><td>{}{}</td><td>{}</td><td class=\"num\">{} \u2192 {}</td><td class=\"num\">{} [{}, {}]</td><td class=\"num\">{}</td>"
          "<td class=\"num\">{}</td><td>{}</td><td>{}</td></tr>\n",
          passes ? " class=\"pass\"" : "", format_value(member(c, "name")), passes ? " \u2714" : "", format_assignments(member(c, "extra_parameters")),
          format_number(number_at(c, "heldout_before")), format_number(number_at(c, "heldout_after")), format_percent(number_at(c, "gain")),
          format_percent(number_at(c, "gain_low")), format_percent(number_at(c, "gain_high")), format_percent(number_at(c, "placebo_gain")),
          format_number(number_at(c, "score")), format_changes(member(c, "base_before"), member(c, "base_after")),
          warnings.empty() ? kNoValueText : warnings);
    }
    html += "</table>\n";
  }
  const json& controls = member(data, "discretization_controls");
  if (has_items(controls) && controls.is_array()) {
    html += "<p>Discretization controls: the base model on a finer discretization. What one removes is the model's own "
            "discretization error; a candidate must beat the larger gain as it must beat the placebo's.</p>\n"
            "<table class=\"controls\">\n<tr><th>control</th><th>what</th><th>fitted parameters</th>"
            "<th>gain [90 % interval]</th></tr>\n";
    for (const json& k : controls) {
      const bool fitted = member(k, "fitted").is_boolean() && member(k, "fitted").get<bool>();
      html += fitted ? fmt::format("<tr><td>{}</td><td>{}</td><td>{}</td><td class=\"num\">{} [{}, {}]</td></tr>\n",
                                   format_value(member(k, "name")), format_value(member(k, "what")),
                                   format_assignments(member(k, "parameters")), format_percent(number_at(k, "gain")),
                                   format_percent(number_at(k, "gain_low")), format_percent(number_at(k, "gain_high")))
                     : fmt::format("<tr><td>{}</td><td colspan=\"3\">not fitted: {}</td></tr>\n",
                                   format_value(member(k, "name")), format_value(member(k, "why_not")));
    }
    html += "</table>\n";
  }
  const json& confounded = member(data, "confounded");
  if (has_items(confounded) && confounded.is_array()) {
    html += "<ul class=\"confounded\">\n";
    for (const json& group : confounded) {
      if (!group.is_array() || group.empty()) continue;
      std::string names;
      for (size_t i = 0; i < group.size(); ++i)
        names += (i == 0 ? "" : i + 1 == group.size() ? " or " : ", ") + ("<b>" + format_value(group[i]) + "</b>");
      std::string values;  // the base parameters the pair's fits differ in (diagnosis.json's confounded_base)
      const json& differ = member(data, "confounded_base");
      const json& units = member(member(data, "parameters"), "units");
      if (group.size() == 2 && differ.is_array())
        for (const json& e : differ) {
          const std::vector<double> v = numbers_at(e, "values");
          if (member(e, "models") != group || v.size() != 2) continue;
          const std::string name = text_at(e, "parameter"), unit = text_at(units, name.c_str());
          auto value = [&](double x) { return format_number(x) + (unit.empty() ? "" : " " + escape_html(unit)); };
          values += fmt::format("{}{} {} with {}, {} with {}", values.empty() ? "" : "; ", escape_html(name), value(v[0]),
                                format_value(group[0]), value(v[1]), format_value(group[1]));
        }
      html += fmt::format("<li>{}, indistinguishable with this data{}</li>\n", names,
                          values.empty() ? "" : "; " + values + ": these data cannot tell which");
    }
    html += "</ul>\n";
  }
  return html;
}

// ---- 2b. how the fits ended -------------------------------------------------------------------

// One row per fit (the base, each candidate, each control) that lists its starts: how many
// converged, their iterations, their stop reasons counted; and, for the base and the cause, the
// held-in cost of every start over its iterations, relative to the fit's lowest (log scale), so
// that a start still falling at the iteration limit shows.
std::string fits_html(const json& data) {
  struct Fit {
    std::string name;
    const json* convergence;
  };
  std::vector<Fit> fits;
  if (has_items(member(member(data, "base_convergence"), "per_start")))
    fits.push_back({"base", &member(data, "base_convergence")});
  for (const char* list : {"candidates", "discretization_controls"}) {
    const json& items = member(data, list);
    if (items.is_array())
      for (const json& c : items)
        if (has_items(member(member(c, "convergence"), "per_start")))
          fits.push_back({text_at(c, "name"), &member(c, "convergence")});
  }
  if (fits.empty()) return "";
  std::string html =
      "<table class=\"fits\">\n<tr><th>fit</th><th>starts converged</th><th>iterations</th><th>stop reasons</th></tr>\n";
  std::vector<PlotPanel> panels;
  const std::string cause = text_at(data, "cause");
  for (const Fit& f : fits) {
    const json& starts = member(*f.convergence, "per_start");
    int converged = 0, fewest = -1, most = -1, n = 0;
    std::vector<std::pair<std::string, int>> reasons;
    for (const json& s : starts) {
      const std::string reason = text_at(s, "stop_reason");
      converged += reason.rfind("converged", 0) == 0;
      const double it = number_at(s, "iterations");
      if (std::isfinite(it)) {
        fewest = fewest < 0 ? int(it) : std::min(fewest, int(it));
        most = std::max(most, int(it));
      }
      auto r = std::find_if(reasons.begin(), reasons.end(), [&](const auto& p) { return p.first == reason; });
      if (r == reasons.end())
        reasons.push_back({reason, 1});
      else
        ++r->second;
      ++n;
    }
    std::string reason_text;
    for (const auto& [reason, count] : reasons)
      reason_text += (reason_text.empty() ? "" : "<br>") +
                     fmt::format("{} \u00d7 {}", count, escape_html(reason.empty() ? "?" : reason));
    const std::string iterations = fewest < 0     ? std::string(kNoValueText)
                                   : fewest == most ? std::to_string(fewest)
                                                    : fmt::format("{}\u2013{}", fewest, most);
    html += fmt::format("<tr{}><td>{}</td><td class=\"num\">{} of {}</td><td class=\"num\">{}</td><td>{}</td></tr>\n",
                        converged < n ? " class=\"unconverged\"" : "", escape_html(f.name), converged, n, iterations,
                        reason_text);
    if (f.name != "base" && f.name != cause) continue;
    double lowest = std::numeric_limits<double>::infinity();
    for (const json& s : starts)
      for (double c : numbers_at(s, "costs"))
        if (std::isfinite(c) && c > 0) lowest = std::min(lowest, c);
    if (!std::isfinite(lowest)) continue;
    PlotPanel panel;
    panel.title = f.name == "base" ? "the base model's starts" : "the cause's starts (" + f.name + ")";
    panel.x_label = "iteration";
    panel.y_label = "held-in cost / the fit's lowest";
    panel.log_y = true;
    int k = 0;
    for (const json& s : starts) {
      PlotSeries series;
      series.color = plot_color(k++);
      for (double c : numbers_at(s, "costs"))
        if (std::isfinite(c) && c > 0) {
          series.x.push_back(double(series.x.size()));
          series.y.push_back(c / lowest);
        }
      series.markers = series.x.size() <= 40;
      if (!series.x.empty()) panel.series.push_back(std::move(series));
    }
    panels.push_back(std::move(panel));
  }
  html += "</table>\n";
  if (!panels.empty()) html += "<figure>\n" + svg_plot_string(panels, 900, 240) + "</figure>\n";
  return html;
}

// ---- 3. residual over time -----------------------------------------------------------------

std::string residual_over_time_html(const json& data) {
  const json& r = member(data, "residual_vs_time");
  std::vector<double> time = numbers_at(r, "time");
  const std::vector<double> before = numbers_at(r, "before_mm"), after = numbers_at(r, "after_mm");
  if (before.empty() && after.empty()) return "";
  PlotPanel panel;
  panel.title = "per-frame RMS residual";
  panel.x_label = "time [s]";
  panel.y_label = "RMS residual [mm]";
  panel.zero_line = true;  // an RMS residual: show how far from 0 it is
  if (time.empty()) {  // no time stamps: plot against the frame number
    for (size_t i = 0; i < std::max(before.size(), after.size()); ++i) time.push_back(double(i));
    panel.x_label = "frame";
  }
  // The legend goes above the plot, in HTML, where it cannot hide the curves.
  const char *before_colour = "#e8590c", *after_colour = "#5f3dc4";
  panel.series.push_back({"", time, before, before_colour, 2.0, time.size() <= 60});
  panel.series.push_back({"", time, after, after_colour, 2.0, time.size() <= 60});
  std::string legend = fmt::format("<span class=\"line\" style=\"background:{}\"></span>before <span class=\"line\" style=\"background:{}\"></span>after",
                                   before_colour, after_colour);
  PlotPanelMarks marks;
  marks.shade_from_x = number_at(r, "heldout_from");
  marks.shade_label = "held-out frames";
  if (std::isfinite(marks.shade_from_x)) legend += " <span class=\"shade\"></span>held-out frames (not fitted)";
  for (double t : numbers_at(r, "contact_times"))
    if (std::isfinite(t)) panel.vertical_lines.push_back(t), marks.vertical_line_labels.push_back("contact");
  if (!panel.vertical_lines.empty()) legend += " <span class=\"dash\"></span>contact event";
  return "<figure>\n<div class=\"legend\">" + legend + "</div>\n" + svg_plot_string({panel}, 900, 340, {marks}) + "</figure>\n";
}

// ---- 4. residual images --------------------------------------------------------------------

// One image, each pixel a unit square of the viewBox (runs of equal colour merged), scaled
// up by a whole number where it fits in 320 px.
std::string residual_image_svg(const std::vector<double>& values, int width, int height, double range) {
  const double scale = width <= 320 ? std::min(8, std::max(1, 320 / width)) : 320.0 / width;
  std::string svg = fmt::format(
      "<svg xmlns=\"http://www.w3.org/2000/svg\" class=\"residual-image\" width=\"{:.0f}\" height=\"{:.0f}\" viewBox=\"0 0 {} {}\" "
      "shape-rendering=\"crispEdges\">\n",
      width * scale, height * scale, width, height);
  auto value_at = [&](size_t i) { return i < values.size() ? values[i] : kNoValue; };
  for (int y = 0; y < height; ++y) {
    int run_start = 0;
    std::string run_colour = diverging_colour(value_at(size_t(y) * width), range);
    for (int x = 1; x <= width; ++x) {
      const std::string colour = x < width ? diverging_colour(value_at(size_t(y) * width + x), range) : "";
      if (colour == run_colour) continue;
      svg += fmt::format("<rect x=\"{}\" y=\"{}\" width=\"{}\" height=\"1\" fill=\"{}\"/>", run_start, y, x - run_start, run_colour);
      run_start = x, run_colour = colour;
    }
    svg += "\n";
  }
  return svg + "</svg>\n";
}

std::string residual_images_html(const json& data) {
  const json& images = member(data, "residual_images");
  if (!has_items(images) || !images.is_array()) return "";
  std::vector<std::vector<double>> before, after;
  std::vector<const std::vector<double>*> all;
  for (const json& image : images) {
    before.push_back(numbers_at(image, "before_mm"));
    after.push_back(numbers_at(image, "after_mm"));
  }
  for (size_t i = 0; i < images.size(); ++i) all.push_back(&before[i]), all.push_back(&after[i]);
  const double range = robust_range(all);
  std::string html = "<p class=\"note\">Signed residual per pixel; one colour scale for all images.</p>\n" + colour_bar_svg(range, "no observed point");
  for (size_t i = 0; i < images.size(); ++i) {
    const json& image = images[i];
    const double w = number_at(image, "width"), h = number_at(image, "height");
    const std::string caption = fmt::format("camera {}, frame {}, t = {} s", format_value(member(image, "camera")),
                                            format_number(number_at(image, "frame")), format_number(number_at(image, "time")));
    if (!(w >= 1 && h >= 1 && w * h <= 16e6 && w == std::floor(w) && h == std::floor(h))) {
      html += fmt::format("<p class=\"note\">{}: no valid image size.</p>\n", caption);
      continue;
    }
    html += "<figure>\n<div class=\"pair\">\n";
    for (const auto& [label, values] : {std::pair{"before", &before[i]}, std::pair{"after", &after[i]}}) {
      if (values->empty()) continue;
      html += fmt::format("<div><div class=\"label\">{}</div>{}</div>\n", label, residual_image_svg(*values, int(w), int(h), range));
    }
    html += fmt::format("</div>\n<figcaption>{}</figcaption>\n</figure>\n", caption);
  }
  return html;
}

// ---- 5. residual on the rest shape ---------------------------------------------------------

using Point = std::array<double, 3>;

// Front (x-y) and side (z-y) views of the points, coloured by value, one metric scale for both.
std::string rest_shape_svg(const std::vector<Point>& points, const std::vector<double>& values, double range) {
  const double box = 260, margin = 24;
  Point lo, hi;
  lo.fill(std::numeric_limits<double>::infinity()), hi.fill(-std::numeric_limits<double>::infinity());
  for (const Point& p : points)
    if (std::isfinite(p[0] + p[1] + p[2]))
      for (int a = 0; a < 3; ++a) lo[a] = std::min(lo[a], p[a]), hi[a] = std::max(hi[a], p[a]);
  const double extent = std::max({hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2], 1e-12});
  const double scale = (box - 2 * margin) / extent;
  // Draw the largest residuals last, on top; at most 20000 points per view.
  std::vector<size_t> order;
  const size_t stride = points.size() / 20000 + 1;
  for (size_t i = 0; i < points.size(); i += stride) order.push_back(i);
  auto magnitude = [&](size_t i) { return i < values.size() && std::isfinite(values[i]) ? std::abs(values[i]) : -1.0; };
  std::stable_sort(order.begin(), order.end(), [&](size_t a, size_t b) { return magnitude(a) < magnitude(b); });

  std::string svg = fmt::format("<svg xmlns=\"http://www.w3.org/2000/svg\" class=\"rest-shape\" width=\"{}\" height=\"{}\" font-size=\"12\">\n",
                                2 * box + 10, box + 20);
  const int horizontal_axes[2] = {0, 2};
  const char* view_names[2] = {"front: x right, y up", "side: z right, y up"};
  for (int view = 0; view < 2; ++view) {
    const int h = horizontal_axes[view];
    const double ox = view * (box + 10);
    const double cx = ox + box / 2 - scale * (lo[h] + hi[h]) / 2, cy = box / 2 + scale * (lo[1] + hi[1]) / 2;
    svg += fmt::format("<rect x=\"{}\" y=\"0\" width=\"{}\" height=\"{}\" fill=\"#fcfcfc\" stroke=\"#bbb\"/>\n", ox, box, box);
    svg += fmt::format("<text x=\"{}\" y=\"{}\" text-anchor=\"middle\">{}</text>\n<g stroke=\"#999\" stroke-width=\"0.4\">\n", ox + box / 2,
                       box + 15, view_names[view]);
    for (size_t i : order) {
      const Point& p = points[i];
      if (!std::isfinite(p[0] + p[1] + p[2])) continue;
      svg += fmt::format("<circle cx=\"{:.1f}\" cy=\"{:.1f}\" r=\"2.2\" fill=\"{}\"/>", cx + scale * p[h], cy - scale * p[1],
                         diverging_colour(i < values.size() ? values[i] : kNoValue, range));
    }
    svg += "\n</g>\n";
  }
  return svg + "</svg>\n";
}

std::string rest_shape_html(const json& data) {
  const json& rest = member(data, "rest_shape");
  const json& raw_points = member(rest, "points");
  if (!has_items(raw_points) || !raw_points.is_array()) return "";
  std::vector<Point> points;
  for (const json& p : raw_points)
    points.push_back(p.is_array() && p.size() == 3 ? Point{as_number(p[0]), as_number(p[1]), as_number(p[2])} : Point{kNoValue, kNoValue, kNoValue});
  const std::vector<double> before = numbers_at(rest, "before_mm"), after = numbers_at(rest, "after_mm");
  const double range = robust_range({&before, &after});
  std::string html = fmt::format("<p class=\"note\">{} matched observed points at their rest-shape position, coloured by their residual.</p>\n",
                                 points.size());
  html += colour_bar_svg(range, "no residual") + "<div class=\"pair\">\n";
  for (const auto& [label, values] : {std::pair{"before", &before}, std::pair{"after", &after}})
    if (!values->empty())  // `ssc residuals` has one model: no "after"
      html += fmt::format("<figure><div class=\"label\">{}</div>{}</figure>\n", label, rest_shape_svg(points, *values, range));
  return html + "</div>\n";
}

// ---- 6. parameters -------------------------------------------------------------------------

std::string parameters_html(const json& data) {
  const json& parameters = member(data, "parameters");
  const json &base = member(parameters, "base"), &winner = member(parameters, "winner"), &units = member(parameters, "units");
  std::vector<std::string> keys;
  for (const json* object : {&base, &winner})
    if (object->is_object())
      for (const auto& item : object->items())
        if (std::find(keys.begin(), keys.end(), item.key()) == keys.end()) keys.push_back(item.key());
  if (keys.empty()) return "";
  std::string html = "<table class=\"parameters\">\n<tr><th>parameter</th><th>base</th><th>winner</th><th>unit</th></tr>\n";
  for (const std::string& key : keys) {
    const json& unit = member(units, key.c_str());
    html += fmt::format("<tr><td>{}</td><td class=\"num\">{}</td><td class=\"num\">{}</td><td>{}</td></tr>\n", escape_html(key),
                        format_value(member(base, key.c_str())), format_value(member(winner, key.c_str())),
                        unit.is_string() ? escape_html(unit.get<std::string>()) : "");
  }
  return html + "</table>\n";
}

const char* const kStyle = R"(
body { font-family: "DejaVu Sans", "Helvetica Neue", Arial, sans-serif; color: #222; line-height: 1.45;
       max-width: 1120px; margin: 24px auto; padding: 0 16px; background: white; }
h1 { font-size: 1.4em; margin: 0 0 0.3em; }
h2 { font-size: 1.25em; border-bottom: 1px solid #ccc; padding-bottom: 3px; margin-top: 1.8em; }
.cause { font-size: 1.9em; font-weight: bold; margin: 0.2em 0 0.4em; }
.cause.none { color: #666; }
ul.summary { font-size: 1.05em; }
table { border-collapse: collapse; font-size: 14px; margin: 8px 0; }
th, td { border: 1px solid #ddd; padding: 4px 8px; text-align: left; vertical-align: top; }
th { background: #f3f3f3; }
td.num { text-align: right; font-variant-numeric: tabular-nums; white-space: nowrap; }
tr.pass { background: #ebfbee; }
tr.unconverged td:nth-child(2) { color: #c92a2a; }
table.candidates { width: 100%; font-size: 12px; }
table.candidates td { overflow-wrap: anywhere; }
table.provenance { font-size: 12px; color: #444; }
table.provenance th { background: none; font-weight: normal; color: #777; }
figure { margin: 10px 0 18px; }
figcaption { font-size: 13px; color: #444; margin-top: 4px; }
.pair { display: flex; flex-wrap: wrap; gap: 24px; align-items: flex-start; }
.pair figure { margin: 0; }
.label { font-size: 13px; font-weight: bold; margin-bottom: 2px; }
.note { font-size: 13px; color: #666; }
.legend { font-size: 13px; margin-left: 80px; }
.legend span { display: inline-block; vertical-align: middle; margin: 0 5px 0 14px; }
.legend span.line { width: 24px; height: 3px; }
.legend span.shade { width: 16px; height: 12px; background: #e8e8e8; border: 1px solid #ccc; }
.legend span.dash { width: 0; height: 14px; border-left: 2px dashed #444; }
svg { display: block; font-family: "DejaVu Sans", Arial, sans-serif; }
svg.residual-image { outline: 1px solid #bbb; }
)";

}  // namespace

std::string render_report_html(const nlohmann::json& data) {
  const std::string title = text_at(data, "title").empty() ? "ssc diagnose" : text_at(data, "title");
  std::string html = fmt::format(
      "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n<title>{}</title>\n<style>{}</style>\n</head>\n<body>\n",
      escape_html(title), kStyle);
  html += header_html(data, title);
  html += section("Candidates", candidates_html(data));
  html += section("Fits", fits_html(data));
  html += section("Residual over time", residual_over_time_html(data));
  html += section("Residual images", residual_images_html(data));
  html += section("Residual on the rest shape", rest_shape_html(data));
  html += section("Parameters", parameters_html(data));
  return html + "</body>\n</html>\n";
}

void write_report_html(const std::string& path, const nlohmann::json& data) {
  const std::string html = render_report_html(data);
  const std::string temp = fmt::format("{}.tmp-{}", path, getpid());
  try {
    write_text_file(temp, html);
  } catch (...) {
    std::remove(temp.c_str());
    throw;
  }
  if (std::rename(temp.c_str(), path.c_str()) != 0) {
    std::remove(temp.c_str());
    throw InputError(fmt::format("{}: cannot move the report into place; check that the folder is writable", path));
  }
}

}  // namespace ssc
