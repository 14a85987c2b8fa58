// SVG line plots (see svg_plot.h).
#include "models/io/svg_plot.h"

#include <fmt/format.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <limits>

#include "models/io/text_file.h"
#include "models/io/write_error.h"
#include "runtime/errors.h"

namespace ssc {
namespace {

struct Axis {
  double lo, hi;
  bool log;
  double map(double v, double a, double b) const {
    const double t = log ? (std::log10(v) - std::log10(lo)) / (std::log10(hi) - std::log10(lo)) : (v - lo) / (hi - lo);
    return a + t * (b - a);
  }
};

Axis make_axis(const std::vector<const std::vector<double>*>& values, bool log, const std::vector<double>& extra) {
  double lo = std::numeric_limits<double>::infinity(), hi = -lo;
  auto take = [&](double v) {
    if (!std::isfinite(v) || (log && v <= 0)) return;
    lo = std::min(lo, v);
    hi = std::max(hi, v);
  };
  for (const auto* vs : values)
    for (double v : *vs) take(v);
  for (double v : extra) take(v);
  if (!std::isfinite(lo)) lo = 0, hi = 1;
  if (hi == lo) {
    const double pad = lo == 0 ? 1 : std::abs(lo) * 0.1;
    lo -= pad, hi += pad;
  } else if (!log) {
    const double pad = 0.05 * (hi - lo);
    lo -= pad, hi += pad;
  }
  return {lo, hi, log};
}

std::vector<double> ticks(const Axis& a) {
  if (!a.log) return plot_ticks(a.lo, a.hi);
  std::vector<double> t;
  for (int e = int(std::floor(std::log10(a.lo))); e <= int(std::ceil(std::log10(a.hi))); ++e)
    for (double m : {1.0, 2.0, 5.0}) {
      const double v = m * std::pow(10.0, e);
      if (v >= a.lo && v <= a.hi) t.push_back(v);
    }
  // A range within one decade may hold none of 1, 2, 5 x 10^e, or one: round linear values then.
  if (t.size() < 2) {
    t.clear();
    for (double v : plot_ticks(a.lo, a.hi))
      if (v > 0) t.push_back(v);
  }
  return t;
}

// A white outline under a label keeps it readable over the curves.
const char* const kHalo = " paint-order=\"stroke\" stroke=\"white\" stroke-width=\"3\" stroke-linejoin=\"round\"";

std::string escape(const std::string& s) {
  std::string o;
  for (char c : s) o += c == '<' ? "&lt;" : c == '>' ? "&gt;" : c == '&' ? "&amp;" : std::string(1, c);
  return o;
}

}  // namespace

std::vector<double> plot_ticks(double lo, double hi) {
  std::vector<double> t;
  if (!std::isfinite(lo) || !std::isfinite(hi) || !(hi > lo)) return t;
  const double raw = (hi - lo) / 6, mag = std::pow(10.0, std::floor(std::log10(raw)));
  const double step = raw / mag < 2 ? 2 * mag : raw / mag < 5 ? 5 * mag : 10 * mag;
  for (double v = std::ceil(lo / step) * step; v <= hi + 1e-12 * step; v += step) t.push_back(std::abs(v) < 1e-12 * step ? 0 : v);
  return t;
}

std::string plot_color(int index) {
  static const char* colors[] = {"#1f77b4", "#d62728", "#2ca02c", "#ff7f0e", "#9467bd", "#8c564b", "#e377c2", "#7f7f7f", "#bcbd22", "#17becf"};
  return colors[index % 10];
}

std::string svg_plot_string(const std::vector<PlotPanel>& panels, int width, int panel_height, const std::vector<PlotPanelMarks>& all_marks) {
  const int left = 80, right = 20, top = 30, bottom = 50;
  std::string svg = fmt::format(
      "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{}\" height=\"{}\" font-family=\"sans-serif\" font-size=\"12\">\n"
      "<rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n",
      width, panel_height * int(panels.size()));
  for (size_t p = 0; p < panels.size(); ++p) {
    const PlotPanel& panel = panels[p];
    static const PlotPanelMarks no_marks;
    const PlotPanelMarks& marks = p < all_marks.size() ? all_marks[p] : no_marks;
    const double y0 = double(p) * panel_height;
    const double px0 = left, px1 = width - right, py0 = y0 + panel_height - bottom, py1 = y0 + top;
    std::vector<const std::vector<double>*> xs, ys;
    for (const PlotSeries& s : panel.series) xs.push_back(&s.x), ys.push_back(&s.y);
    std::vector<double> x_marks = panel.vertical_lines;
    if (std::isfinite(marks.shade_from_x)) x_marks.push_back(marks.shade_from_x);
    const Axis ax = make_axis(xs, panel.log_x, x_marks);
    const Axis ay = make_axis(ys, panel.log_y, panel.zero_line ? std::vector<double>{0.0} : std::vector<double>{});
    svg += fmt::format("<text x=\"{}\" y=\"{}\" text-anchor=\"middle\" font-size=\"14\">{}</text>\n", (px0 + px1) / 2, y0 + 18, escape(panel.title));
    std::string labels;  // labels of the marks, drawn over the curves
    if (std::isfinite(marks.shade_from_x) && (!ax.log || marks.shade_from_x > 0)) {
      const double sx = std::clamp(ax.map(marks.shade_from_x, px0, px1), px0, px1);
      svg += fmt::format("<rect x=\"{:.1f}\" y=\"{}\" width=\"{:.1f}\" height=\"{}\" fill=\"#e8e8e8\"/>\n", sx, py1, px1 - sx, py0 - py1);
      if (!marks.shade_label.empty())
        svg += fmt::format("<text x=\"{}\" y=\"{}\" text-anchor=\"end\" font-size=\"11\" fill=\"#555\">shaded: {}</text>\n", px1, py1 - 4,
                           escape(marks.shade_label));
    }
    svg += fmt::format("<rect x=\"{}\" y=\"{}\" width=\"{}\" height=\"{}\" fill=\"none\" stroke=\"black\"/>\n", px0, py1, px1 - px0, py0 - py1);
    for (double t : ticks(ax)) {
      const double x = ax.map(t, px0, px1);
      svg += fmt::format("<line x1=\"{0}\" y1=\"{1}\" x2=\"{0}\" y2=\"{2}\" stroke=\"#ddd\"/><text x=\"{0}\" y=\"{3}\" text-anchor=\"middle\">{4:.4g}</text>\n", x, py0, py1, py0 + 16, t);
    }
    for (double t : ticks(ay)) {
      const double y = ay.map(t, py0, py1);
      svg += fmt::format("<line x1=\"{1}\" y1=\"{0}\" x2=\"{2}\" y2=\"{0}\" stroke=\"#ddd\"/><text x=\"{3}\" y=\"{4}\" text-anchor=\"end\">{5:.4g}</text>\n", y, px0, px1, px0 - 6, y + 4, t);
    }
    if (panel.zero_line && ay.lo < 0 && ay.hi > 0)
      svg += fmt::format("<line x1=\"{1}\" y1=\"{0}\" x2=\"{2}\" y2=\"{0}\" stroke=\"black\" stroke-dasharray=\"4,3\"/>\n", ay.map(0, py0, py1), px0, px1);
    for (size_t i = 0; i < panel.vertical_lines.size(); ++i) {
      const double x = ax.map(panel.vertical_lines[i], px0, px1);
      svg += fmt::format("<line x1=\"{0}\" y1=\"{1}\" x2=\"{0}\" y2=\"{2}\" stroke=\"#444\" stroke-dasharray=\"6,3\"/>\n", x, py0, py1);
      if (i < marks.vertical_line_labels.size() && !marks.vertical_line_labels[i].empty())
        labels += fmt::format("<text x=\"{:.1f}\" y=\"{}\" font-size=\"11\" fill=\"#444\"{}>{}</text>\n", x + 3, py1 + 12, kHalo,
                              escape(marks.vertical_line_labels[i]));
    }
    svg += fmt::format("<text x=\"{}\" y=\"{}\" text-anchor=\"middle\">{}</text>\n", (px0 + px1) / 2, py0 + 36, escape(panel.x_label));
    svg += fmt::format("<text x=\"{0}\" y=\"{1}\" text-anchor=\"middle\" transform=\"rotate(-90 {0} {1})\">{2}</text>\n", 18, (py0 + py1) / 2, escape(panel.y_label));
    int legend = 0;
    for (const PlotSeries& s : panel.series) {
      std::string points;
      for (size_t i = 0; i < s.x.size() && i < s.y.size(); ++i) {
        if (!std::isfinite(s.x[i]) || !std::isfinite(s.y[i]) || (ax.log && s.x[i] <= 0) || (ay.log && s.y[i] <= 0)) continue;
        const double x = ax.map(s.x[i], px0, px1), y = ay.map(s.y[i], py0, py1);
        points += fmt::format("{:.1f},{:.1f} ", x, y);
        if (s.markers) svg += fmt::format("<circle cx=\"{:.1f}\" cy=\"{:.1f}\" r=\"2.5\" fill=\"{}\"/>\n", x, y, s.color);
      }
      svg += fmt::format("<polyline points=\"{}\" fill=\"none\" stroke=\"{}\" stroke-width=\"{}\"/>\n", points, s.color, s.width);
      if (!s.label.empty()) {
        const double ly = py1 + 14 + 14 * legend++;
        svg += fmt::format("<line x1=\"{0}\" y1=\"{1}\" x2=\"{2}\" y2=\"{1}\" stroke=\"{3}\" stroke-width=\"2\"/><text x=\"{4}\" y=\"{5}\">{6}</text>\n",
                           px1 - 150, ly, px1 - 130, s.color, px1 - 125, ly + 4, escape(s.label));
      }
    }
    svg += labels;
  }
  svg += "</svg>\n";
  return svg;
}

void write_svg_plot(const std::string& path, const std::vector<PlotPanel>& panels, int width, int panel_height) {
  const std::string svg = svg_plot_string(panels, width, panel_height);
  const std::string temp = fmt::format("{}.tmp-{}", path, getpid());
  try {
    write_text_file(temp, svg);
  } catch (const InputError&) {
    std::remove(temp.c_str());
    throw;
  }
  if (std::rename(temp.c_str(), path.c_str()) != 0) {
    const int err = errno;
    std::remove(temp.c_str());
    throw_write_error(path, err, "move the plot into place");
  }
}

}  // namespace ssc
