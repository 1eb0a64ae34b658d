#pragma once
// The plots of the reports, drawn by gnuplot (gnuplot.hpp) as inline SVG.

#include <optional>
#include <string>
#include <vector>

#include "dbbkit/design.hpp"
#include "dbbkit/identify.hpp"

namespace dbbkit::io {

// One line of a line plot; lo/hi (same length as x, or empty) draw a band.
// NaN values are gaps (a value the data cannot determine).
struct PlotSeries {
  std::string title;
  std::vector<double> x, y, lo, hi;
  std::string style = "linespoints";  // gnuplot style of the line: linespoints, lines, points
  std::vector<std::string> labels;    // written beside the points (empty, or one per point)
};
// y_max (when given): the y axis runs from 0 to it, points above it are off the plot.
std::string plot_series(const std::string& title, const std::string& xlabel,
                        const std::string& ylabel, const std::vector<PlotSeries>& series,
                        int width_px = 760, int height_px = 380, std::optional<double> y_max = {});

// The design drawn in its body frame (the machine frame at angle 0): a top
// view (x, y) and a side view (x, z) with every ball position, its id, and the
// bar to the following ball (or the reading direction, 40 mm, when no bar is given).
std::string plot_design(const Design& design);

// The six errors against angle, translations and rotations in two panels: the
// value (or 0 for an a-priori evaluation) with a band of +-U.
std::string plot_errors(const std::vector<ExpandedErrorsAtAngle>& errors, bool values,
                        const std::string& title);

// The residual of each installation in a panel of its own (small multiples, one scale for
// all), each sweep (cw, ccw, not recorded; each repeat) a line of its own in angle order.
struct ResidualLine {
  std::string sweep;  // "ccw", "cw", "sweep not recorded"; a repeat adds " #n"
  std::vector<double> angle_deg, residual_um;
};
struct ResidualPanel {
  std::string installation;
  std::vector<ResidualLine> lines;
};
std::string plot_residual_panels(const std::string& title,
                                 const std::vector<ResidualPanel>& panels);
// The same residuals as a ballbar shows them: each installation a closed trace around a
// circle of radius `base_um`, out where the bar read longer than the model, in where shorter
// (radius = base + residual), against the angle.
std::string plot_residual_polar(const std::string& title, const std::vector<ResidualPanel>& panels);

// A point marked on a heat map, with its label.
struct HeatmapMark {
  double x = 0, y = 0;
  std::string label;  // no double quote
};
// A heat map of z over a grid (x fastest); NaN cells are left blank. The colour map is
// viridis (perceptually uniform, readable in grey); the colour scale runs from the smallest z
// to z_max when given (larger values take the top colour), else to the largest.
std::string plot_heatmap(const std::string& title, const std::string& xlabel,
                         const std::string& ylabel, const std::string& zlabel,
                         const std::vector<double>& x, const std::vector<double>& y,
                         const std::vector<double>& z, std::optional<double> z_max = {},
                         const std::vector<HeatmapMark>& marks = {});

}  // namespace dbbkit::io
