#include "dbbkit/io/predict_io.hpp"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <functional>
#include <iomanip>
#include <map>
#include <sstream>

#include "csv_cells.hpp"
#include "dbbkit/error.hpp"
#include "dbbkit/io/escape.hpp"
#include "dbbkit/io/json_reader.hpp"
#include "dbbkit/io/result_io.hpp"
#include "dbbkit/io/text.hpp"
#include "dbbkit/iso230.hpp"
#include "dbbkit/limits.hpp"
#include "dbbkit/user_text.hpp"
#include "result_blocks.hpp"

namespace dbbkit::io {

using nlohmann::json;

std::string angle_text(double a) {
  const std::string short_form = fmt_rounded(a, 3);
  return std::stod(short_form) == a ? short_form : fmt_num(a, 15);
}

const char* basis_key(PredictionBasis b) {
  return b == PredictionBasis::kMotions ? "motions" : "location";
}

namespace {

const std::array<const char*, 4> kPoseColumns = {"angle_deg", "x_mm", "y_mm", "z_mm"};

json vec3(const Eigen::Vector3d& v) { return json::array({r6(v.x()), r6(v.y()), r6(v.z())}); }

Eigen::Vector3d stds(const Eigen::Matrix3d& c) { return c.diagonal().cwiseMax(0.0).cwiseSqrt(); }

// What follows an angle beyond the axis' travel in an error.
std::string beyond_travel(const AxisFrame& axis) {
  return " deg is beyond the travel of the " + axis.label() + " axis (" +
         fmt_num(axis.travel_min_deg(), 12) + " to " + fmt_num(axis.travel_max_deg(), 12) + " deg)";
}

// The basis as the table shows it.
std::string basis_text(const PointPrediction& x) {
  if (x.basis == PredictionBasis::kMotions) return "motions";
  return x.location_reason == LocationReason::kNoMotionCovariance ? "location, no covariance"
                                                                  : "location";
}

const char* location_reason_text(LocationReason r) {
  switch (r) {
    case LocationReason::kNotMeasured:
      return "an angle the result did not measure: the component motions there are not known and "
             "are not in the error nor in U";
    case LocationReason::kNoMotionCovariance:
      return "the result states the component motions here without their covariance (an earlier "
             "version, or diagnose's shares of equivalent effects): the location errors alone";
    case LocationReason::kAsked:
      return "asked (--location-only): the component motions are not in the error nor in U";
  }
  return "";
}

}  // namespace

void check_pose(const Pose& p, const AxisFrame& axis, const std::string& source,
                const std::string& where) {
  if (!(p.angle_deg >= axis.travel_min_deg() && p.angle_deg <= axis.travel_max_deg()))
    throw InputError(source, where + "angle_deg", fmt_num(p.angle_deg, 12) + beyond_travel(axis));
  for (int k = 0; k < 3; ++k) {
    if (!(std::abs(p.point_mm(k)) <= limits::kMaxLength_mm))
      throw InputError(source, where + kPoseColumns[static_cast<std::size_t>(k + 1)],
                       fmt_num(p.point_mm(k), 12) + " mm is beyond +-" +
                           fmt_num(limits::kMaxLength_mm, 12) + " mm");
  }
}

void for_each_pose_row(const std::string& text, const std::string& source,
                       const std::vector<std::string>& names, const std::string& expected,
                       const std::function<void(const std::function<double(const std::string&)>&,
                                                const std::string&)>& row) {
  std::istringstream in(csv::lf_lines(text));
  std::string raw;
  int line_no = 0;
  std::vector<std::string> header;
  std::map<std::string, int> col;
  std::size_t rows = 0;
  while (std::getline(in, raw)) {
    ++line_no;
    if (line_no == 1 && raw.size() >= 3 && raw.compare(0, 3, "\xEF\xBB\xBF") == 0) raw.erase(0, 3);
    if (csv::trim(raw).empty()) continue;
    const std::string where = "line " + std::to_string(line_no);
    if (raw.find('"') != std::string::npos)
      throw InputError(source, where, "quoted fields are not supported (numbers need no quotes)");
    const std::vector<std::string> cells = csv::split(raw);
    if (header.empty()) {
      header = cells;
      for (std::size_t i = 0; i < header.size(); ++i) {
        if (std::find(names.begin(), names.end(), header[i]) == names.end())
          throw InputError(
              source, where,
              "unknown column " + quote_value(header[i]) + " (expected " + expected + ")");
        if (!col.emplace(header[i], static_cast<int>(i)).second)
          throw InputError(source, where, "column " + quote_value(header[i]) + " appears twice");
      }
      for (const std::string& c : names)
        if (!col.count(c))
          throw InputError(source, where, "required column '" + c + "' is missing");
      continue;
    }
    if (cells.size() != header.size())
      throw InputError(source, where,
                       "expected " + std::to_string(header.size()) + " fields, found " +
                           std::to_string(cells.size()));
    if (rows >= limits::kMaxPoses)
      throw InputError(source, where,
                       "more than " + std::to_string(limits::kMaxPoses) + " poses in one file");
    ++rows;
    row(
        [&](const std::string& name) {
          return csv::Cell{source, line_no, name, cells[static_cast<std::size_t>(col.at(name))]}
              .number();
        },
        where);
  }
  if (header.empty()) {
    std::string joined;
    for (const std::string& n : names) joined += (joined.empty() ? "" : ",") + n;
    throw InputError(source, "line 1", "empty: expected the header " + joined);
  }
  if (rows == 0) throw InputError(source, "line " + std::to_string(line_no), "no pose");
}

std::vector<Pose> parse_poses(const std::string& text, const std::string& source,
                              const AxisFrame& axis) {
  std::vector<Pose> poses;
  for_each_pose_row(
      text, source, {kPoseColumns.begin(), kPoseColumns.end()},
      "angle_deg, x_mm, y_mm, z_mm: a point fixed to the body that turns, body frame, from the "
      "axis frame's origin",
      [&](const std::function<double(const std::string&)>& number, const std::string& where) {
        Pose p;
        p.angle_deg = number("angle_deg");
        for (int k = 0; k < 3; ++k)
          p.point_mm(k) = number(kPoseColumns[static_cast<std::size_t>(k + 1)]);
        check_pose(p, axis, source, where + ", column ");
        poses.push_back(p);
      });
  return poses;
}

std::vector<Pose> read_poses_file(const std::string& path, const AxisFrame& axis) {
  return parse_poses(read_text_file(path), path, axis);
}

std::vector<double> parse_number_list(const std::string& text, const std::string& key) {
  std::vector<double> out;
  std::size_t begin = 0;
  for (int item = 1;; ++item) {
    const std::size_t end = std::min(text.find(',', begin), text.size());
    const std::string cell = csv::trim(text.substr(begin, end - begin));
    const std::string where = "item " + std::to_string(item);
    if (cell.empty())
      throw InputError(key, where, "empty: expected numbers separated by commas, e.g. 0,100,200");
    double x = 0;
    if (!parse_decimal(cell, x))
      throw InputError(key, where,
                       quote_value(cell) + " is not a finite number in decimal notation");
    out.push_back(x);
    if (end == text.size()) break;
    begin = end + 1;
  }
  return out;
}

EnvelopeGrid grid_of(const ResultFile& result, const GridRequest& request, const GridKeys& keys) {
  EnvelopeGrid grid;
  grid.radii_mm = request.radii_mm;
  grid.heights_mm = request.heights_mm.value_or(std::vector<double>{0.0});
  if (request.angles_deg) {
    grid.angles_deg = *request.angles_deg;
  } else {
    for (const ResultErrors& e : result.errors) grid.angles_deg.push_back(e.angle_deg);
  }
  grid.around = request.around;
  const AxisFrame& axis = result.axis;
  // Each list: an item, each finite, no value twice, each within its range.
  auto check = [](const std::vector<double>& v, const std::string& key, const char* what,
                  const std::function<std::string(double)>& beyond) {
    if (v.empty()) throw InputError(key, "", std::string("no ") + what);
    for (std::size_t i = 0; i < v.size(); ++i) {
      const std::string where = "item " + std::to_string(i + 1);
      if (!std::isfinite(v[i])) throw InputError(key, where, "not a finite number");
      const std::string why = beyond(v[i]);
      if (!why.empty()) throw InputError(key, where, fmt_num(v[i], 12) + why);
      for (std::size_t j = 0; j < i; ++j)
        if (v[j] == v[i])
          throw InputError(key, where,
                           fmt_num(v[i], 12) + " is item " + std::to_string(j + 1) +
                               " as well: each value once");
    }
  };
  check(grid.radii_mm, keys.radii, "radius", [](double r) {
    return r == 0 || (r >= limits::kMinGridRadius_mm && r <= limits::kMaxLength_mm)
               ? std::string()
               : " mm: a radius is 0 (the axis line) or from " +
                     fmt_num(limits::kMinGridRadius_mm, 12) + " to " +
                     fmt_num(limits::kMaxLength_mm, 12) + " mm";
  });
  check(grid.heights_mm, keys.heights, "height", [](double h) {
    return std::abs(h) <= limits::kMaxLength_mm
               ? std::string()
               : " mm is beyond +-" + fmt_num(limits::kMaxLength_mm, 12) + " mm";
  });
  check(grid.angles_deg, keys.angles, "angle", [&axis](double a) {
    return a >= axis.travel_min_deg() && a <= axis.travel_max_deg() ? std::string()
                                                                    : beyond_travel(axis);
  });
  if (grid.around < 1 || grid.around > 360)
    throw InputError(keys.around, "", std::to_string(grid.around) + " is outside 1 to 360");
  for (const double r : grid.radii_mm)
    for (const double h : grid.heights_mm)
      if (std::hypot(r, h) > limits::kMaxLength_mm)
        throw InputError(keys.radii, "",
                         "a radius of " + fmt_num(r, 12) + " mm at a height of " + fmt_num(h, 12) +
                             " mm puts points beyond " + fmt_num(limits::kMaxLength_mm, 12) +
                             " mm from the axis frame's origin");
  double n = 0;
  for (const double r : grid.radii_mm) n += r == 0 ? 1 : grid.around;
  n *= static_cast<double>(grid.heights_mm.size()) * static_cast<double>(grid.angles_deg.size());
  if (n > static_cast<double>(limits::kMaxPoses))
    throw InputError(keys.radii, "",
                     "the map would hold " + fmt_num(n, 3) + " points, more than " +
                         std::to_string(limits::kMaxPoses) +
                         ": give fewer angles, radii, heights or points around");
  return grid;
}

AxisErrors axis_errors_of(const ResultFile& result) {
  AxisErrors a;
  a.axis = result.axis;
  if (result.location.size() != 5)
    throw InputError(result.source, "iso230.location", "expected the axis' five location errors");
  if (!result.location_covariance)
    throw InputError(result.source, "iso230.location_covariance",
                     "missing: a prediction needs the location errors' covariance (a result of an "
                     "earlier version: run identify again)");
  const IsoNames names = iso230_names(result.axis);
  for (int k = 0; k < 5; ++k) {
    if (result.location[k].name != names.location[static_cast<std::size_t>(k)])
      throw InputError(
          result.source, "iso230.location[" + std::to_string(k) + "].name",
          "expected " + names.location[static_cast<std::size_t>(k)] + " (ISO 230-1's order)");
    a.location[static_cast<std::size_t>(k)] = result.location[k].value;
  }
  a.location_covariance = *result.location_covariance;
  {  // No measurement gives a covariance with a negative variance in any direction (beyond the
     // rounding of its entries to 1e-6).
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, 5, 5>> eig(a.location_covariance);
    const double least = eig.eigenvalues()(0), most = eig.eigenvalues()(4);
    if (!(least >= -1e-5 - 1e-9 * std::abs(most)))
      throw InputError(result.source, "iso230.location_covariance.matrix",
                       "not positive semidefinite (an eigenvalue of " + fmt_num(least, 4) +
                           "): no measurement gives it");
  }
  for (const ResultComponents& c : result.components) {
    if (!c.motion_covariance) {
      if (c.all_determined()) a.measured_without_covariance.push_back(c.angle_deg);
      continue;
    }
    AxisErrors::AtAngle at;
    at.angle_deg = c.angle_deg;
    for (int k = 0; k < 6; ++k) at.component[static_cast<std::size_t>(k)] = *c.motions[k].value;
    at.covariance = *c.motion_covariance;
    at.errors_covariance = c.errors_covariance;
    for (const ResultErrors& e : result.errors) {
      if (!same_angle(result.axis, e.angle_deg, c.angle_deg)) continue;
      if (std::all_of(e.value.begin(), e.value.end(),
                      [](const auto& v) { return v.has_value(); })) {
        Eigen::Matrix<double, 6, 1> m;
        for (int k = 0; k < 6; ++k) m(k) = *e.value[static_cast<std::size_t>(k)];
        at.errors = m;
      }
      break;
    }
    a.measured.push_back(at);
  }
  if (result.constants.size() == 5 &&
      std::all_of(result.constants.begin(), result.constants.end(),
                  [](const ResultQuantity& q) { return q.value && q.std; })) {
    Eigen::Matrix<double, 5, 1> k;
    for (int q = 0; q < 5; ++q) {
      k(q) = *result.constants[static_cast<std::size_t>(q)].value;
      a.constants_std(q) = *result.constants[static_cast<std::size_t>(q)].std;
    }
    a.constants = k;
  }
  a.dof = result.dof;
  a.independent_between_angles = result.independent_between_angles;
  return a;
}

PredictResult predict(const ResultFile& result, const std::vector<Pose>& poses,
                      double coverage_probability, bool location_only) {
  const AxisErrors axis = axis_errors_of(result);
  PredictResult p;
  p.result_source = result.source;
  p.axis_label = result.axis.label();
  p.letter = result.axis.letter();
  p.location_only = location_only;
  p.location_names = iso230_names(result.axis).location;
  p.coverage = prediction_coverage(coverage_probability, axis.dof);
  p.warnings = result.warnings;
  p.points.reserve(poses.size());
  for (const Pose& pose : poses)
    p.points.push_back(predict_point(axis, pose, p.coverage, location_only));
  return p;
}

namespace {

// The index of the largest error among the determined points (after entering: the largest
// estimate plus its U); -1: none.
int largest(const PredictResult& p, bool after) {
  int at = -1;
  double top = -1;
  // Where some points have the component motions, only those: a point without them would look
  // smaller than it is.
  const bool motions = std::any_of(p.points.begin(), p.points.end(), [](const PointPrediction& x) {
    return x.gap == PredictionGap::kNone && x.basis == PredictionBasis::kMotions;
  });
  for (std::size_t i = 0; i < p.points.size(); ++i) {
    const PointPrediction& x = p.points[i];
    if (x.gap != PredictionGap::kNone) continue;
    if (motions && x.basis != PredictionBasis::kMotions) continue;
    // After entering, what may remain: the estimate's length and its U.
    const double n = after ? x.after_um.norm() + x.after_U_um : x.error_um.norm();
    if (n > top) top = n, at = static_cast<int>(i);
  }
  return at;
}

std::string method_text(const PredictResult& p) {
  std::ostringstream s;
  s << "first order (model.md): a point P0 of the body (body frame, from the axis frame's origin) "
       "at the commanded angle is off by d + e x P, (d, e) the error motions less their "
       "constant parts: the location errors' part ("
    << p.location_names[0] << ", " << p.location_names[1] << ", " << p.location_names[2] << ", "
    << p.location_names[3] << ", " << p.location_names[4]
    << ") and, at an angle the result measured, the component error motions, with their joint "
       "covariance; at another angle the location errors alone (the component motions there are "
       "not known and are left out). After entering: the location errors entered, what remains "
       "with the same uncertainty. std per coordinate (k = 1); U_um: the true error vector lies "
       "within U_um of the predicted one with the coverage probability (Gaussian: the radius of "
       "that probability; with degrees of freedom: at least it)";
  return s.str();
}

}  // namespace

json prediction_to_json(const PredictResult& p) {
  json points = json::array();
  for (const PointPrediction& x : p.points) {
    json j{{"angle_deg", x.pose.angle_deg},
           {"point_mm", vec3(x.pose.point_mm)},
           {"nominal_mm", vec3(x.nominal_mm)}};
    if (x.gap != PredictionGap::kNone) {
      j["determined"] = false;
      j["reason"] = "the result does not determine every location error";
      points.push_back(j);
      continue;
    }
    j["determined"] = true;
    j["basis"] = basis_key(x.basis);
    if (x.basis == PredictionBasis::kLocationOnly)
      j["location_reason"] = location_reason_text(x.location_reason);
    j["error_um"] = vec3(x.error_um);
    j["std_um"] = vec3(stds(x.covariance));
    j["U_um"] = r6(x.U_um);
    j["covariance_um2"] = {vec3(x.covariance.row(0)), vec3(x.covariance.row(1)),
                           vec3(x.covariance.row(2))};
    j["after_entering"] = {{"error_um", vec3(x.after_um)},
                           {"std_um", vec3(stds(x.after_covariance))},
                           {"U_um", r6(x.after_U_um)}};
    points.push_back(j);
  }
  json out{{"format", kPredictFormat},
           {"inputs", {{"result", p.result_source}, {"poses", p.poses_source}}},
           {"axis", p.axis_label},
           {"error",
            "the point's true position minus its nominal one, machine frame, um (on a "
            "table the tool meets the workpiece's point off by minus this; on a head the "
            "tool tip is off by it)"},
           {"method", method_text(p)},
           {"coverage_probability", p.coverage.coverage_probability},
           {"k", p.coverage.k},
           {"k_length", p.coverage.k_length},
           {"dof", p.coverage.dof ? json(r6(*p.coverage.dof)) : json(nullptr)},
           {"location_only", p.location_only},
           {"points", points}};
  if (!p.result_sha256.empty()) out["inputs"]["result_sha256"] = p.result_sha256;
  if (p.grid)
    out["grid"] = {{"radii_mm", p.grid->radii_mm},
                   {"heights_mm", p.grid->heights_mm},
                   {"around", p.grid->around},
                   {"angles_deg", p.grid->angles_deg}};
  json warnings = json::array();
  for (const std::string& w : p.warnings) warnings.push_back(w);
  out["result_warnings"] = warnings;
  for (const bool after : {false, true}) {
    const int i = largest(p, after);
    if (i < 0) continue;
    const PointPrediction& x = p.points[static_cast<std::size_t>(i)];
    out["largest"][after ? "after_entering" : "error"] = {
        {"point", i},
        {"length_um", r6((after ? x.after_um : x.error_um).norm())},
        {"U_um", r6(after ? x.after_U_um : x.U_um)}};
  }
  return out;
}

std::string prediction_text(const PredictResult& p, bool rows) {
  std::ostringstream s;
  s << "predict: " << p.points.size() << " point" << (p.points.size() == 1 ? "" : "s") << " of the "
    << p.axis_label << " axis' body from " << terminal_text(p.result_source) << "\n";
  for (const std::string& w : p.warnings)
    s << "Warning (the result's; its uncertainties may be too small): " << terminal_text(w) << "\n";
  s << "error: the point's true minus nominal position, machine frame, um; U: the true error "
       "vector lies within U of it with "
    << (p.coverage.dof ? "at least " : "") << fmt_num(100 * p.coverage.coverage_probability, 4)
    << " %"
    << (p.coverage.dof ? " (t, " + fmt_num(*p.coverage.dof, 3) + " degrees of freedom)"
                       : std::string(" (Gaussian)"))
    << " where the basis is motions; where it is location, of the location errors' part alone\n";
  if (p.location_only)
    s << "the location errors alone at every angle (--location-only): the component error motions "
         "are left out\n";
  if (rows)
    s << std::setw(10) << "angle deg" << std::setw(26) << "point mm (x, y, z)" << std::setw(28)
      << "error um (x, y, z)" << std::setw(8) << "|e|" << std::setw(7) << "U" << std::setw(10)
      << "after |e|" << std::setw(7) << "U"
      << "  basis\n";
  auto triple = [](const Eigen::Vector3d& v, int decimals) {
    return "(" + fmt_rounded(v.x(), decimals) + ", " + fmt_rounded(v.y(), decimals) + ", " +
           fmt_rounded(v.z(), decimals) + ")";
  };
  bool location_only = false;
  if (!rows) {
    int gaps = 0;
    for (const PointPrediction& x : p.points) {
      location_only = location_only ||
                      (x.gap == PredictionGap::kNone && x.basis == PredictionBasis::kLocationOnly);
      gaps += x.gap != PredictionGap::kNone;
    }
    s << "a map of " << p.points.size() << " points (each in the JSON, --out)";
    if (gaps > 0)
      s << "; " << gaps << " not determined: the result does not determine every location error";
    s << "\n";
  }
  for (const PointPrediction& x : p.points) {
    if (!rows) break;
    s << std::setw(10) << angle_text(x.pose.angle_deg) << std::setw(26)
      << triple(x.pose.point_mm, 1);
    if (x.gap != PredictionGap::kNone) {
      s << "  not determined: the result does not determine every location error\n";
      continue;
    }
    location_only = location_only || x.basis == PredictionBasis::kLocationOnly;
    s << std::setw(28) << triple(x.error_um, 2) << std::setw(8) << fmt_rounded(x.error_um.norm(), 2)
      << std::setw(7) << fmt_rounded(x.U_um, 2) << std::setw(10)
      << fmt_rounded(x.after_um.norm(), 2) << std::setw(7) << fmt_rounded(x.after_U_um, 2) << "  "
      << basis_text(x) << "\n";
  }
  for (const bool after : {false, true}) {
    const int i = largest(p, after);
    if (i < 0) continue;
    const PointPrediction& x = p.points[static_cast<std::size_t>(i)];
    s << (after ? "Largest after entering the location errors: " : "Largest error: ")
      << fmt_rounded((after ? x.after_um : x.error_um).norm(), 2) << " um (U "
      << fmt_rounded(after ? x.after_U_um : x.U_um, 2) << " um) at " << p.letter << " "
      << angle_text(x.pose.angle_deg) << " deg, point " << triple(x.pose.point_mm, 1) << " mm\n";
  }
  bool no_covariance = false;
  for (const PointPrediction& x : p.points)
    no_covariance = no_covariance ||
                    (x.gap == PredictionGap::kNone && x.basis == PredictionBasis::kLocationOnly &&
                     x.location_reason == LocationReason::kNoMotionCovariance);
  if (!p.location_only)
    s << "basis motions: the location errors and the component error motions at an angle the "
         "result measured";
  if (location_only && !p.location_only)
    s << "; location: an angle not measured, the location errors alone (the component error "
         "motions there are not known and are left out, of the error and of U)";
  if (no_covariance)
    s << "; location, no covariance: " << location_reason_text(LocationReason::kNoMotionCovariance);
  if (p.location_only) s << "basis location: the location errors alone";
  s << ".\nOn a table the tool meets the workpiece's point off by minus the error; on a head the "
       "tool tip is off by it.\n";
  return s.str();
}

}  // namespace dbbkit::io
