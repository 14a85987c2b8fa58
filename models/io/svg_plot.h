// Minimal line plots written as SVG (no plotting library in Debian's C++ packages fits):
// one or more panels stacked vertically, each with axes, ticks, labels, a legend and any
// number of series (optionally drawn thick, with markers, or on a log x axis).
#pragma once
#include <string>
#include <vector>

namespace ssc {

struct PlotSeries {
  std::string label;
  std::vector<double> x, y;
  std::string color = "#1f77b4";
  double width = 1.5;
  bool markers = false;
};

struct PlotPanel {
  std::string title, x_label, y_label;
  bool log_x = false, log_y = false;
  bool zero_line = false;  // horizontal line at y = 0
  std::vector<double> vertical_lines;  // e.g. the ground truth
  std::vector<PlotSeries> series;
};

// Writes the panels atomically to path (temp file + rename).
void write_svg_plot(const std::string& path, const std::vector<PlotPanel>& panels, int width = 720, int panel_height = 300);

// A palette of distinguishable colours, cycled by index.
std::string plot_color(int index);

}  // namespace ssc
