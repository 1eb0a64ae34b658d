#include "dbbkit/io/plots.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <utility>

#include "dbbkit/io/gnuplot.hpp"
#include "dbbkit/kinematics.hpp"

namespace dbbkit::io {

namespace {

// Two balls of the design drawing share a point (and its label) when both coordinates differ
// by less than kSamePoint_mm.
constexpr double kSamePoint_mm = 1e-6;

const char* kColours[] = {"#1f77b4", "#d62728", "#2ca02c", "#9467bd",
                          "#ff7f0e", "#17becf", "#8c564b", "#e377c2"};

std::string series_block(const PlotSeries& s, int index) {
  std::ostringstream b;
  b << "$d" << index << " << EOD\n";
  for (size_t i = 0; i < s.x.size(); ++i) {
    b << gnuplot_number(s.x[i]) << " " << gnuplot_number(s.y[i]);
    if (!s.lo.empty()) b << " " << gnuplot_number(s.lo[i]) << " " << gnuplot_number(s.hi[i]);
    if (s.lo.empty() && i < s.labels.size()) b << " \"" << gnuplot_label(s.labels[i]) << "\"";
    b << "\n";
  }
  b << "EOD\n";
  return b.str();
}

std::string series_plot(const PlotSeries& s, int index) {
  const std::string colour = kColours[index % 8];
  std::ostringstream p;
  if (!s.lo.empty()) {
    p << "$d" << index << " using 1:3:4 with filledcurves fc rgb '" << colour
      << "' fs transparent solid 0.18 noborder notitle, ";
  }
  p << "$d" << index << " using 1:2 with " << s.style << " lc rgb '" << colour
    << "' lw 1.5 pt 7 ps 0.5 title " << gnuplot_quote(s.title);
  if (s.lo.empty() && !s.labels.empty())
    p << ", $d" << index
      << " using 1:2:3 with labels offset 0.6,0.6 left rotate by 50 boxed font ',9' tc rgb '"
      << colour << "' notitle";
  return p.str();
}

}  // namespace

std::string plot_series(const std::string& title, const std::string& xlabel,
                        const std::string& ylabel, const std::vector<PlotSeries>& series,
                        int width_px, int height_px, std::optional<double> y_max) {
  std::ostringstream s;
  for (size_t i = 0; i < series.size(); ++i) s << series_block(series[i], static_cast<int>(i));
  s << "set title " << gnuplot_quote(title) << "\nset xlabel " << gnuplot_quote(xlabel)
    << "\nset ylabel " << gnuplot_quote(ylabel) << "\nset grid\nset key outside right top\n";
  if (y_max && *y_max > 0) s << "set yrange [0:" << gnuplot_number(*y_max) << "]\n";
  s << "set style textbox opaque fillcolor rgb '#ffffff' noborder\nplot ";
  for (size_t i = 0; i < series.size(); ++i)
    s << (i ? ", " : "") << series_plot(series[i], static_cast<int>(i));
  s << "\n";
  return gnuplot_svg(s.str(), width_px, height_px);
}

std::string plot_design(const Design& design) {
  std::ostringstream bars;
  bars << "$bars << EOD\n";
  std::vector<std::pair<Eigen::Vector3d, std::string>> balls;  // ball position, installation id
  for (const Installation& in : design.installations) {
    const Eigen::Vector3d P = ball_body_mm(design.axis, in);
    const double length = in.bar_mm ? *in.bar_mm : 40.0;
    const Eigen::Vector3d F = in.bar_mm ? Eigen::Vector3d(P - in.sign * length * in.direction.body)
                                        : Eigen::Vector3d(P + length * in.direction.body);
    bars << gnuplot_number(P.x()) << " " << gnuplot_number(P.y()) << " " << gnuplot_number(P.z())
         << " " << gnuplot_number(F.x() - P.x()) << " " << gnuplot_number(F.y() - P.y()) << " "
         << gnuplot_number(F.z() - P.z()) << "\n";
    balls.emplace_back(P, in.id);
  }
  bars << "EOD\n";
  // The labels of each view: installations whose balls project to one point share a label
  // (e.g. two axial readings on the axis at different heights, seen from above); along the
  // view's horizontal axis, neighbouring labels alternate above and below their point, so
  // that balls close together keep readable labels.
  auto labels = [&](const std::string& name, int h, int v) {
    struct Point {
      double x, y;
      std::string ids;
    };
    std::vector<Point> points;
    for (const auto& [P, id] : balls) {
      bool found = false;
      for (Point& q : points) {
        if (std::abs(q.x - P(h)) < kSamePoint_mm && std::abs(q.y - P(v)) < kSamePoint_mm) {
          if (("," + q.ids + ",").find("," + id + ",") == std::string::npos) q.ids += "," + id;
          found = true;
        }
      }
      if (!found) points.push_back({P(h), P(v), id});
    }
    // Along each level of the view's vertical coordinate, by the horizontal one: $<name>0
    // holds every other point from the first (labels above), $<name>1 the rest (below).
    std::stable_sort(points.begin(), points.end(), [](const Point& a, const Point& b) {
      return a.y < b.y || (a.y == b.y && a.x < b.x);
    });
    std::array<std::vector<const Point*>, 2> sets;
    for (size_t i = 0, k = 0; i < points.size(); ++i) {
      k = i > 0 && std::abs(points[i].y - points[i - 1].y) < kSamePoint_mm ? k + 1 : 0;
      sets[k % 2].push_back(&points[i]);
    }
    std::ostringstream d, plot;
    for (size_t parity = 0; parity < 2; ++parity) {
      if (sets[parity].empty()) continue;
      d << "$" << name << parity << " << EOD\n";
      for (const Point* q : sets[parity])
        d << gnuplot_number(q->x) << " " << gnuplot_number(q->y) << " \"" << gnuplot_label(q->ids)
          << "\"\n";
      d << "EOD\n";
      plot << ", $" << name << parity << " using 1:2 with points pt 7 ps 1.2 lc rgb '#d62728', $"
           << name << parity << " using 1:2:3 with labels offset 0," << (parity == 0 ? "1" : "-1")
           << " font 'sans,9'";
    }
    return std::make_pair(d.str(), plot.str());
  };
  // The axis of rotation is drawn where it lies in a view's plane (a dashed line through the
  // origin) or where it pierces it (a cross): about z (C), y (B) or x (A); a nutating axis is
  // not drawn.
  const int along = design.axis.machine_axis();
  const std::string what =
      design.installations.front().bar_mm ? "bar to the following ball" : "reading direction";
  const auto [top_data, top_plot] = labels("top", 0, 1);
  const auto [side_data, side_plot] = labels("side", 0, 2);
  std::ostringstream s;
  s << bars.str() << top_data << side_data << "set multiplot layout 1,2 title "
    << gnuplot_quote(std::string("axis ") + design.axis.label() +
                     ", body frame = machine frame at angle 0; lines: " + what)
    << "\nset size ratio -1\nset grid\nset key off\nset offsets graph 0.08, graph 0.08, graph "
       "0.08, graph 0.08\n";
  // Top view x, y (the axis z pierces it); side view x, z (the axis y pierces it). A line
  // along the view's vertical axis (x = 0) or its horizontal one (the other = 0).
  const char* vertical = "set arrow 1 from 0,graph 0 to 0,graph 1 nohead dt 2 lc rgb '#888888'\n";
  const char* horizontal =
      "set arrow 1 from graph 0,first 0 to graph 1,first 0 nohead dt 2 lc rgb '#888888'\n";
  const char* cross = ", '+' using (0):(0) with points pt 2 ps 2 lc rgb '#888888'";
  s << "set title 'top view (x, y) [mm]'\nset xlabel 'x [mm]'\nset ylabel 'y [mm]'\n";
  if (along == 1) s << vertical;
  if (along == 0) s << horizontal;
  s << "plot $bars using 1:2:4:5 with vectors nohead lw 2 lc rgb '#1f77b4'" << top_plot
    << (along == 2 ? cross : "") << "\n";
  s << "unset arrow 1\nset title 'side view (x, z) [mm]'\nset xlabel 'x [mm]'\nset ylabel 'z "
       "[mm]'\n";
  if (along == 2) s << vertical;
  if (along == 0) s << horizontal;
  s << "plot $bars using 1:3:4:6 with vectors nohead lw 2 lc rgb '#1f77b4'" << side_plot
    << (along == 1 ? cross : "") << "\n";
  s << "unset multiplot\n";
  return gnuplot_svg(s.str(), 900, 420);
}

std::string plot_errors(const std::vector<ExpandedErrorsAtAngle>& errors, bool values,
                        const std::string& title) {
  std::vector<PlotSeries> tr, rot;
  for (int e = 0; e < 6; ++e) {
    PlotSeries s;
    s.title = kErrorNames[e];
    for (const ExpandedErrorsAtAngle& ea : errors) {
      const ExpandedValue& d = ea.errors[e];
      const double v =
          d.determined ? (values ? d.value : 0.0) : std::numeric_limits<double>::quiet_NaN();
      const double U = d.determined ? d.U : std::numeric_limits<double>::quiet_NaN();
      s.x.push_back(ea.angle_deg);
      s.y.push_back(values ? v : U);
      s.lo.push_back(v - U);
      s.hi.push_back(v + U);
    }
    if (!values) s.lo.clear(), s.hi.clear();
    (e < 3 ? tr : rot).push_back(s);
  }
  std::ostringstream sc;
  int index = 0;
  for (const PlotSeries& s : tr) sc << series_block(s, index++);
  for (const PlotSeries& s : rot) sc << series_block(s, index++);
  const std::string what = values ? "value with band +-U" : "U (a priori)";
  sc << "set multiplot layout 2,1 title " << gnuplot_quote(title)
     << "\nset grid\nset key outside right top\n"
     << "set xlabel 'angle [deg]'\n";
  // A panel with no determined value says so (gnuplot refuses a plot of no valid point).
  double lo = 0, hi = 1;
  if (!errors.empty()) {
    lo = errors.front().angle_deg, hi = lo;
    for (const ExpandedErrorsAtAngle& ea : errors)
      lo = std::min(lo, ea.angle_deg), hi = std::max(hi, ea.angle_deg);
  }
  if (hi <= lo) lo -= 1, hi += 1;
  auto panel = [&](const std::vector<PlotSeries>& series, int first, const std::string& name,
                   const char* unit) {
    sc << "set title " << gnuplot_quote(name + ": " + what) << "\nset ylabel '" << unit << "'\n";
    bool any = false;
    for (const PlotSeries& s : series)
      for (double y : s.y) any = any || std::isfinite(y);
    if (!any) {
      sc << "set xrange [" << gnuplot_number(lo) << ":" << gnuplot_number(hi)
         << "]\nset yrange [0:1]\nset label 1 'not determined at any angle' at graph 0.5, 0.5 "
            "center\nplot 2 notitle\nunset label 1\nset autoscale\n";
      return;
    }
    sc << "plot ";
    for (int i = 0; i < 3; ++i) sc << (i ? ", " : "") << series_plot(series[i], i + first);
    sc << "\n";
  };
  panel(tr, 0, "translations", "um");
  panel(rot, 3, "rotations", "urad");
  sc << "unset multiplot\n";
  return gnuplot_svg(sc.str(), 900, 640);
}

std::string plot_heatmap(const std::string& title, const std::string& xlabel,
                         const std::string& ylabel, const std::string& zlabel,
                         const std::vector<double>& x, const std::vector<double>& y,
                         const std::vector<double>& z, std::optional<double> z_max,
                         const std::vector<HeatmapMark>& marks) {
  std::ostringstream s;
  s << "$map << EOD\n";
  double lo = std::numeric_limits<double>::infinity();
  for (size_t j = 0; j < y.size(); ++j) {
    for (size_t i = 0; i < x.size(); ++i) {
      const double v = z[j * x.size() + i];
      if (std::isfinite(v)) lo = std::min(lo, v);
      s << gnuplot_number(x[i]) << " " << gnuplot_number(y[j]) << " " << gnuplot_number(v) << "\n";
    }
    s << "\n";
  }
  s << "EOD\n";
  if (!marks.empty()) {
    s << "$marks << EOD\n";
    for (const HeatmapMark& m : marks)
      s << gnuplot_number(m.x) << " " << gnuplot_number(m.y) << " \"" << gnuplot_label(m.label)
        << "\"\n";
    s << "EOD\n";
  }
  s << "set title " << gnuplot_quote(title) << "\nset xlabel " << gnuplot_quote(xlabel)
    << "\nset ylabel " << gnuplot_quote(ylabel) << "\nset cblabel " << gnuplot_quote(zlabel)
    << "\nset palette defined (0 '#440154', 0.14 '#46327e', 0.29 '#365c8d', 0.43 '#277f8e', "
       "0.57 '#1fa187', 0.71 '#4ac16d', 0.86 '#a0da39', 1 '#fde725')\nset tics out\n";
  s << "set style textbox opaque fillcolor rgb '#ffffff' noborder\n";
  if (z_max && std::isfinite(lo) && *z_max > lo)
    s << "set cbrange [" << gnuplot_number(lo) << ":" << gnuplot_number(*z_max) << "]\n";
  s << "plot $map using 1:2:3 with image notitle";
  if (!marks.empty())
    s << ", $marks using 1:2 with points pt 7 ps 1.4 lc rgb '#e41a1c' notitle"
      << ", $marks using 1:2:3 with labels offset -1.2,0.9 right boxed tc rgb '#000000' "
         "font ',11' notitle";
  s << "\n";
  return gnuplot_svg(s.str(), 760, 480);
}

std::string plot_residual_panels(const std::string& title,
                                 const std::vector<ResidualPanel>& panels) {
  const int n = static_cast<int>(panels.size());
  if (n == 0) return "";
  const int cols = std::min(n, 4), rows = (n + cols - 1) / cols;
  double lim = 0;
  for (const ResidualPanel& p : panels)
    for (const ResidualLine& l : p.lines)
      for (double r : l.residual_um)
        if (std::isfinite(r)) lim = std::max(lim, std::abs(r));
  lim = lim > 0 ? 1.1 * lim : 1.0;
  std::ostringstream s;
  int block = 0;
  for (const ResidualPanel& p : panels) {
    for (const ResidualLine& l : p.lines) {
      s << "$r" << block++ << " << EOD\n";
      for (size_t k = 0; k < l.angle_deg.size(); ++k)
        s << gnuplot_number(l.angle_deg[k]) << " " << gnuplot_number(l.residual_um[k]) << "\n";
      s << "EOD\n";
    }
  }
  double lo_a = std::numeric_limits<double>::infinity(), hi_a = -lo_a;
  for (const ResidualPanel& p : panels)
    for (const ResidualLine& l : p.lines)
      for (double a : l.angle_deg) lo_a = std::min(lo_a, a), hi_a = std::max(hi_a, a);
  const double span = hi_a > lo_a ? hi_a - lo_a : 1.0;
  const double tic = span > 180 ? 90 : span > 60 ? 30 : span > 20 ? 10 : span / 4;
  s << "set multiplot layout " << rows << "," << cols << " title " << gnuplot_quote(title)
    << "\nset grid\nset yrange [" << gnuplot_number(-lim) << ":" << gnuplot_number(lim)
    << "]\nset xrange [" << gnuplot_number(lo_a) << ":"
    << gnuplot_number(hi_a > lo_a ? hi_a : lo_a + 1) << "]\nset xtics " << gnuplot_number(tic)
    << "\nset xlabel 'angle [deg]'\nset key top right font ',9'\n";
  block = 0;
  for (int k = 0; k < n; ++k) {
    const ResidualPanel& p = panels[k];
    s << "set title " << gnuplot_quote(p.installation) << "\nset ylabel "
      << gnuplot_quote(k % cols == 0 ? "reading - model [um]" : "") << "\nplot ";
    // A key only where a panel has more than one line.
    for (size_t j = 0; j < p.lines.size(); ++j, ++block) {
      s << (j ? ", " : "") << "$r" << block << " using 1:2 with linespoints lc rgb '"
        << kColours[j % 8] << "' lw 1.5 pt 7 ps 0.4 "
        << (p.lines.size() > 1 ? "title " + gnuplot_quote(p.lines[j].sweep) : "notitle");
    }
    s << "\n";
  }
  s << "unset multiplot\n";
  return gnuplot_svg(s.str(), 190 * cols + 40, 200 * rows + 40);
}

std::string plot_residual_polar(const std::string& title,
                                const std::vector<ResidualPanel>& panels) {
  double lim = 0;
  for (const ResidualPanel& p : panels)
    for (const ResidualLine& l : p.lines)
      for (double r : l.residual_um)
        if (std::isfinite(r)) lim = std::max(lim, std::abs(r));
  lim = lim > 0 ? lim : 1.0;
  const double base = 2 * lim;  // the circle the traces deviate from
  std::ostringstream s;
  int block = 0;
  std::ostringstream plot;
  plot << "plot " << gnuplot_number(base) << " with lines dt 2 lc rgb '#888888' title "
       << gnuplot_quote("model (" + gnuplot_number(base) + " um from the centre)");
  for (size_t k = 0; k < panels.size(); ++k) {
    for (const ResidualLine& l : panels[k].lines) {
      s << "$p" << block << " << EOD\n";
      for (size_t j = 0; j < l.angle_deg.size(); ++j)
        s << gnuplot_number(l.angle_deg[j]) << " " << gnuplot_number(base + l.residual_um[j])
          << "\n";
      s << "EOD\n";
      plot << ", $p" << block << " using 1:2 with linespoints lc rgb '" << kColours[k % 8]
           << "' lw 1.5 pt 7 ps 0.4 title "
           << gnuplot_quote(panels[k].lines.size() > 1 ? panels[k].installation + " " + l.sweep
                                                       : panels[k].installation);
      ++block;
    }
  }
  s << "set title " << gnuplot_quote(title) << "\nset polar\nset angles degrees\nset size square"
    << "\nunset border\nunset xtics\nunset ytics\nunset raxis\nunset rtics\nset grid polar 30"
    << "\nset rrange [0:" << gnuplot_number(base + 1.1 * lim)
    << "]\nset key outside right top font ',9'\n"
    << plot.str() << "\n";
  return gnuplot_svg(s.str(), 760, 560);
}

}  // namespace dbbkit::io
