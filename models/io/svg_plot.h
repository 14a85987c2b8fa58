// Minimal line plots written as SVG (no plotting library in Debian's C++ packages fits):
// one or more panels stacked vertically, each with axes, ticks, labels, a legend and any
// number of series (optionally drawn thick, with markers, or on a log x axis). Written to a
// file, or returned as a string to inline into an HTML page (models/diagnosis/report_html.h).
#pragma once
#include <limits>
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

// Optional marks of a panel (kept out of PlotPanel, which callers brace-initialise).
struct PlotPanelMarks {
  std::vector<std::string> vertical_line_labels;  // written at the top of vertical_lines[i], if given
  double shade_from_x = std::numeric_limits<double>::quiet_NaN();  // shades x >= shade_from_x when finite
  std::string shade_label;                                         // written above the panel's top right corner
};

// The panels as one <svg> element (with its xmlns, so it also stands alone as a file);
// marks[i], where given, adds to panels[i].
std::string svg_plot_string(const std::vector<PlotPanel>& panels, int width = 720, int panel_height = 300,
                            const std::vector<PlotPanelMarks>& marks = {});

// Writes the panels atomically to path (temp file + rename).
void write_svg_plot(const std::string& path, const std::vector<PlotPanel>& panels, int width = 720, int panel_height = 300);

// About six round tick values covering [lo, hi] (a linear axis).
std::vector<double> plot_ticks(double lo, double hi);

// A palette of distinguishable colours, cycled by index.
std::string plot_color(int index);

}  // namespace ssc
