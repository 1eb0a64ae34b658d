// The report of `predict`: the largest error at each angle over the points asked about, before
// and after entering the location errors, with U; over a map, where on the envelope it sits.
#include <algorithm>
#include <cmath>
#include <limits>
#include <map>

#include "dbbkit/io/plots.hpp"
#include "dbbkit/io/predict_io.hpp"
#include "dbbkit/io/reports.hpp"
#include "dbbkit/io/text.hpp"
#include "report_sections.hpp"

namespace dbbkit::io {

namespace {

std::string point_text(const Eigen::Vector3d& p) {
  return "(" + fmt_rounded(p.x(), 1) + ", " + fmt_rounded(p.y(), 1) + ", " + fmt_rounded(p.z(), 1) +
         ")";
}

// The point of the largest error (after entering: the largest estimate plus its U) at one angle.
struct AtAngle {
  int before = -1, after = -1;
  int points = 0;
  bool location = false;  // a point predicted from the location errors alone
};

}  // namespace

std::string predict_report(ReportFormat f, const RunContext& run, const PredictResult& p) {
  const std::unique_ptr<ReportWriter> page =
      make_report_writer(f, "dbbkit predict: the " + p.axis_label + " axis");
  ReportWriter& w = *page;
  if (!p.warnings.empty()) {
    w.heading("The result's warnings (its uncertainties may be too small)");
    w.bullets(p.warnings);
  }
  w.heading("Where the points of the body will be off");
  // What is left after entering, as it is ranked: the estimate's size plus its U.
  const auto left_after = [&](int k) {
    const PointPrediction& y = p.points[static_cast<std::size_t>(k)];
    return y.after_um.norm() + y.after_U_um;
  };
  std::map<double, AtAngle> angles;
  int gaps = 0;
  for (std::size_t i = 0; i < p.points.size(); ++i) {
    const PointPrediction& x = p.points[i];
    if (x.gap != PredictionGap::kNone) {
      ++gaps;
      continue;
    }
    AtAngle& a = angles[x.pose.angle_deg];
    ++a.points;
    a.location = a.location || x.basis == PredictionBasis::kLocationOnly;
    const auto at = static_cast<int>(i);
    if (a.before < 0 || x.error_um.norm() > p.points[a.before].error_um.norm()) a.before = at;
    if (a.after < 0 || left_after(at) > left_after(a.after)) a.after = at;
  }
  std::string intro =
      std::to_string(p.points.size()) + " points " +
      (p.grid ? "of a map over the envelope" : "asked about") + " at " +
      std::to_string(angles.size()) + " angles, from " + terminal_text(p.result_source) +
      ". The error: the point's true minus its nominal position (machine frame, "
      "um); U: the radius around it that holds the true error vector with " +
      fmt_num(100 * p.coverage.coverage_probability, 4) + " %" +
      (p.coverage.dof ? " at least (t, " + fmt_num(*p.coverage.dof, 3) + " degrees of freedom)"
                      : std::string(" (Gaussian)")) +
      ". After entering: what remains once the five location errors are entered "
      "in the controller (the component error motions), with the same U.";
  if (p.location_only) intro += " The location errors alone at every angle (--location-only).";
  if (gaps > 0)
    intro += " " + std::to_string(gaps) +
             " points not determined: the result does not determine every location error.";
  w.paragraph(intro);
  if (angles.empty()) {
    detail::conditions(w, run, nullptr);
    return w.str();
  }
  // The largest overall, as the terminal says it.
  int top = -1, top_after = -1;
  for (const auto& [angle, a] : angles) {
    if (top < 0 || p.points[a.before].error_um.norm() > p.points[top].error_um.norm())
      top = a.before;
    if (top_after < 0 || left_after(a.after) > left_after(top_after)) top_after = a.after;
  }
  const PointPrediction& t = p.points[static_cast<std::size_t>(top)];
  const PointPrediction& ta = p.points[static_cast<std::size_t>(top_after)];
  w.bullets(
      {"Largest error: " + fmt_rounded(t.error_um.norm(), 2) + " um (U " + fmt_rounded(t.U_um, 2) +
           " um) at " + p.letter + " " + angle_text(t.pose.angle_deg) + " deg, point " +
           point_text(t.pose.point_mm) + " mm",
       "Largest after entering the location errors: " + fmt_rounded(ta.after_um.norm(), 2) +
           " um (U " + fmt_rounded(ta.after_U_um, 2) + " um) at " + p.letter + " " +
           angle_text(ta.pose.angle_deg) + " deg, point " + point_text(ta.pose.point_mm) + " mm"});
  PlotSeries before, after;
  before.title = "largest error, +-U";
  after.title = "largest after entering, +-U";
  for (const auto& [angle, a] : angles) {
    const PointPrediction& x = p.points[static_cast<std::size_t>(a.before)];
    const PointPrediction& y = p.points[static_cast<std::size_t>(a.after)];
    before.x.push_back(angle);
    before.y.push_back(x.error_um.norm());
    before.lo.push_back(std::max(0.0, x.error_um.norm() - x.U_um));
    before.hi.push_back(x.error_um.norm() + x.U_um);
    after.x.push_back(angle);
    after.y.push_back(y.after_um.norm());
    after.lo.push_back(std::max(0.0, y.after_um.norm() - y.after_U_um));
    after.hi.push_back(y.after_um.norm() + y.after_U_um);
  }
  w.figure(
      [&] {
        return plot_series("the largest error at each angle", std::string(1, p.letter) + " [deg]",
                           "error [um]", {before, after});
      },
      "At each angle the largest error of the points asked about (its length) with its U, and "
      "the largest left once the location errors are entered (ranked by its size plus its U).");
  // An image needs even steps (gnuplot's `with image`): sorted, each step the first's.
  auto even = [](std::vector<double> v) {
    std::sort(v.begin(), v.end());
    for (std::size_t i = 2; i < v.size(); ++i)
      if (std::abs((v[i] - v[i - 1]) - (v[1] - v[0])) > 1e-9 * (1 + std::abs(v[1] - v[0])))
        return false;
    return v.size() >= 2;
  };
  std::vector<double> map_angles;
  for (const auto& [angle, a] : angles) map_angles.push_back(angle);
  if (p.grid && !(even(p.grid->radii_mm) && even(map_angles)))
    w.paragraph(
        "No heat map: the map's radii or angles are not evenly spaced (the table gives "
        "each angle's largest error).");
  if (p.grid && even(p.grid->radii_mm) && even(map_angles)) {
    // Where on the envelope: the largest error over the heights and the points around, for each
    // angle and distance from the axis line.
    std::vector<double> xs, ys = p.grid->radii_mm, zs;
    for (const auto& [angle, a] : angles) xs.push_back(angle);
    std::sort(ys.begin(), ys.end());
    // The points in the map's order (angle, radius, height, around; one point at radius 0).
    std::map<std::pair<double, double>, double> cell;
    double top_radius = 0;
    std::size_t k = 0;
    for (const double angle : p.grid->angles_deg)
      for (const double r : p.grid->radii_mm)
        for (std::size_t h = 0; h < p.grid->heights_mm.size(); ++h) {
          const int n = r == 0 ? 1 : std::max(1, p.grid->around);
          for (int q = 0; q < n; ++q, ++k) {
            if (static_cast<int>(k) == top) top_radius = r;
            const PointPrediction& x = p.points[k];
            if (x.gap != PredictionGap::kNone) continue;
            double& c = cell[{angle, r}];
            c = std::max(c, x.error_um.norm());
          }
        }
    for (const double r : ys)
      for (const double a : xs) {
        const auto it = cell.find({a, r});
        zs.push_back(it == cell.end() ? std::numeric_limits<double>::quiet_NaN() : it->second);
      }
    const std::vector<HeatmapMark> marks = {
        {t.pose.angle_deg, top_radius, "largest " + fmt_rounded(t.error_um.norm(), 1) + " um"}};
    w.figure(
        [&] {
          return plot_heatmap("the largest error over the heights and around",
                              std::string(1, p.letter) + " [deg]", "distance from the axis [mm]",
                              "error [um]", xs, ys, zs, std::nullopt, marks);
        },
        "The map: at each angle and distance from the axis line, the largest error over the "
        "heights along the axis and the points around the circle.");
  }
  std::vector<std::vector<std::string>> rows;
  for (const auto& [angle, a] : angles) {
    const PointPrediction& x = p.points[static_cast<std::size_t>(a.before)];
    const PointPrediction& y = p.points[static_cast<std::size_t>(a.after)];
    rows.push_back({angle_text(angle), std::to_string(a.points),
                    a.location ? "location" : "motions", fmt_rounded(x.error_um.norm(), 2),
                    fmt_rounded(x.U_um, 2), point_text(x.pose.point_mm),
                    fmt_rounded(y.after_um.norm(), 2), fmt_rounded(y.after_U_um, 2),
                    point_text(y.pose.point_mm)});
  }
  w.table({"angle [deg]", "points", "basis", "largest |e| [um]", "U [um]",
           "point (body frame) [mm]", "after |e| [um]", "U [um]", "point (body frame) [mm]"},
          rows);
  w.paragraph(
      "basis motions: the location errors and the component error motions the result identified "
      "at that angle; location: the location errors alone (an angle the result did not measure: "
      "the component motions there are not known and are left out, of the error and of U). On a "
      "table the tool meets the workpiece's point off by minus the error; on a head the tool tip "
      "is off by it.");
  detail::conditions(w, run, nullptr);
  return w.str();
}

}  // namespace dbbkit::io
