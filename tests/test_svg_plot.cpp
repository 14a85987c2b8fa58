// The SVG line plots (models/io/svg_plot.h): every axis gets tick labels, a log axis whose
// range lies within one decade included (a converged fit's cost, 3.1e-5 .. 4.8e-5).
#include <gtest/gtest.h>

#include <string>

#include "models/io/svg_plot.h"

namespace ssc {
namespace {

int count(const std::string& s, const std::string& what) {
  int n = 0;
  for (size_t at = s.find(what); at != std::string::npos; at = s.find(what, at + 1)) ++n;
  return n;
}

TEST(SvgPlot, ALogAxisWithinOneDecadeStillHasTickLabels) {
  PlotPanel panel;
  panel.title = panel.y_label = "cost";
  panel.log_y = true;
  panel.series.push_back({"start 0", {0, 1, 2, 3}, {4.8e-5, 3.6e-5, 3.2e-5, 3.1e-5}});
  const std::string svg = svg_plot_string({panel});
  // Tick labels are right-aligned text on the y axis; 3.1e-5 .. 4.8e-5 has none of 1, 2, 5 x 10^e.
  EXPECT_GE(count(svg, "text-anchor=\"end\">"), 2) << svg;
  EXPECT_NE(svg.find(">4e-05<"), std::string::npos) << svg;
}

TEST(SvgPlot, ALogAxisOverDecadesKeepsItsRoundValues) {
  PlotPanel panel;
  panel.title = panel.y_label = "cost";
  panel.log_y = true;
  panel.series.push_back({"start 0", {0, 1, 2}, {1e-2, 1e-4, 3e-6}});
  const std::string svg = svg_plot_string({panel});
  EXPECT_NE(svg.find(">0.001<"), std::string::npos) << svg;
  EXPECT_NE(svg.find(">1e-05<"), std::string::npos) << svg;
}

}  // namespace
}  // namespace ssc
