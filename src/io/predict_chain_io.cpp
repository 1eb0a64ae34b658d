// `dbbkit predict --result M.json`: a machine result's chain at the poses a user asks about.
#include <algorithm>
#include <cmath>
#include <iomanip>
#include <map>
#include <sstream>
#include <utility>

#include "csv_cells.hpp"
#include "dbbkit/error.hpp"
#include "dbbkit/io/escape.hpp"
#include "dbbkit/io/json_reader.hpp"
#include "dbbkit/io/predict_io.hpp"
#include "dbbkit/io/result_io.hpp"
#include "dbbkit/io/text.hpp"
#include "dbbkit/limits.hpp"
#include "dbbkit/user_text.hpp"
#include "result_blocks.hpp"

namespace dbbkit::io {

using nlohmann::json;

ChainErrors chain_errors_of(const ChainFile& f) {
  ChainErrors c;
  for (const ChainFileAxis& a : f.axes) {
    ChainErrors::Axis x;
    x.letter = a.letter;
    x.table = a.table;
    x.point_mm = a.point_mm;
    x.direction = a.direction;
    x.vector = a.vector;
    for (std::size_t q = 0; q < 5; ++q) x.location[q] = a.location[q].value;
    c.axes.push_back(x);
  }
  for (std::size_t i = 0; i < f.axes.size(); ++i) {
    if (!f.axes[i].on) continue;
    for (std::size_t j = 0; j < f.axes.size(); ++j)
      if (f.axes[j].letter == f.axes[i].on) c.axes[i].on = static_cast<int>(j);
  }
  c.covariance = f.covariance;
  if (!chain_order(c)) {
    std::string sides;
    for (const ChainFileAxis& a : f.axes)
      sides += (sides.empty() ? "" : ", ") + std::string(1, a.letter) +
               (a.table ? " table" : " head") + (a.on ? std::string(" on ") + a.on : std::string());
    throw InputError(f.source, "axes",
                     "the axes (" + sides +
                         ") are not one chain on each side (every axis but a side's outermost "
                         "carried by the next of the same side): predict each axis' result "
                         "(predict --result with it)");
  }
  return c;
}

std::vector<std::string> chain_pose_columns(const ChainErrors& chain) {
  std::vector<std::string> names;  // the axes' order first
  for (const ChainErrors::Axis& a : chain.axes) names.push_back(std::string(1, a.letter) + "_deg");
  for (const char* c : {"x_mm", "y_mm", "z_mm"}) names.emplace_back(c);
  if (const std::optional<ChainOrder> order = chain_order(chain); order && order->both())
    for (const char* c : {"tool_x_mm", "tool_y_mm", "tool_z_mm"}) names.emplace_back(c);
  return names;
}

ChainPose chain_pose_of(const ChainErrors& chain, const std::vector<std::string>& columns,
                        const std::function<double(std::size_t)>& value, const std::string& source,
                        const std::string& where) {
  ChainPose p;
  for (std::size_t k = 0; k < chain.axes.size(); ++k) {
    const double a = value(k);
    if (!(std::abs(a) <= 36000))
      throw InputError(source, where + ", column " + columns[k],
                       fmt_num(a, 12) + " deg is beyond +-36000 deg");
    p.angles_deg.push_back(a);
  }
  auto point = [&](std::size_t first) {
    Eigen::Vector3d x;
    for (std::size_t k = 0; k < 3; ++k) {
      x(static_cast<Eigen::Index>(k)) = value(first + k);
      if (!(std::abs(x(static_cast<Eigen::Index>(k))) <= limits::kMaxLength_mm))
        throw InputError(source, where + ", column " + columns[first + k],
                         fmt_num(x(static_cast<Eigen::Index>(k)), 12) + " mm is beyond +-" +
                             fmt_num(limits::kMaxLength_mm, 12) + " mm");
    }
    return x;
  };
  p.point_mm = point(chain.axes.size());
  if (columns.size() > chain.axes.size() + 3) p.tool_mm = point(chain.axes.size() + 3);
  return p;
}

std::vector<ChainPose> parse_chain_poses(const std::string& text, const std::string& source,
                                         const ChainErrors& chain) {
  const std::vector<std::string> names = chain_pose_columns(chain);
  const bool tool = names.size() > chain.axes.size() + 3;
  std::string expected;
  for (const std::string& n : names) expected += (expected.empty() ? "" : ", ") + n;
  std::vector<ChainPose> poses;
  for_each_pose_row(
      text, source, names,
      expected +
          (tool ? ": each axis' angle, a point fixed to the workpiece on the innermost table and "
                  "the tool tip in the innermost head, machine frame with every axis at zero"
                : ": each axis' angle, and a point fixed to the innermost body, machine frame "
                  "with every axis at zero"),
      [&](const std::function<double(const std::string&)>& number, const std::string& where) {
        poses.push_back(chain_pose_of(
            chain, names, [&](std::size_t k) { return number(names[k]); }, source, where));
      });
  return poses;
}

ChainPredictResult predict_chain(const ChainFile& f, ChainErrors chain,
                                 const std::vector<ChainPose>& poses, double coverage_probability) {
  ChainPredictResult r;
  r.result_source = f.source;
  r.machine_name = f.machine_name;
  r.chain = std::move(chain);
  r.order = *chain_order(r.chain);
  r.coverage = prediction_coverage(coverage_probability, std::nullopt);
  r.warnings = f.warnings;
  for (const ChainPose& p : poses)
    r.points.push_back(predict_chain_point(r.chain, r.order, p, r.coverage));
  return r;
}

namespace {

json vec_json(const Eigen::Vector3d& v) { return json::array({r6(v.x()), r6(v.y()), r6(v.z())}); }

std::string chain_body_text(const ChainPredictResult& p) {
  auto letter = [&](int i) {
    return std::string(1, p.chain.axes[static_cast<std::size_t>(i)].letter);
  };
  if (p.order.both())
    return "the tool tip in the " + letter(p.order.head.front()) +
           " head against a workpiece's point on the " + letter(p.order.table.front()) + " table";
  return p.order.head.empty()
             ? "a workpiece's point on the " + letter(p.order.table.front()) + " table"
             : "a tool tip in the " + letter(p.order.head.front()) + " head";
}

// The largest error among the determined points, or -1.
int largest_chain_point(const ChainPredictResult& p) {
  int best = -1;
  for (std::size_t i = 0; i < p.points.size(); ++i)
    if (p.points[i].determined &&
        (best < 0 ||
         p.points[i].error_um.norm() > p.points[static_cast<std::size_t>(best)].error_um.norm()))
      best = static_cast<int>(i);
  return best;
}

std::string angles_text(const ChainPredictResult& p, const ChainPose& pose) {
  std::string s;
  for (std::size_t k = 0; k < p.chain.axes.size(); ++k)
    s += (k == 0 ? "" : " ") + std::string(1, p.chain.axes[k].letter) + " " +
         angle_text(pose.angles_deg[k]);
  return s;
}

const char* const kChainError =
    "the point's true minus nominal position (machine frame, um): each axis turned about its "
    "real line, the controller's line moved by the machine result's location errors (in its "
    "carrier's body); the location errors alone (a machine result states no component error "
    "motions: they are not in the error nor in U)";
const char* const kChainToolError =
    "the tool tip's place relative to the workpiece's point, true minus nominal (machine frame, "
    "um): the tool tip's displacement (the head's axes turned about their real lines) minus the "
    "workpiece point's (the table's), the linear axes taken as exact; each real line the "
    "controller's moved by the machine result's location errors (in its carrier's body); the "
    "location errors alone (a machine result states no component error motions: they are not in "
    "the error nor in U)";

const char* chain_error_text(const ChainPredictResult& p) {
  return p.order.both() ? kChainToolError : kChainError;
}

}  // namespace

json chain_prediction_to_json(const ChainPredictResult& p) {
  json points = json::array();
  for (const ChainPointPrediction& x : p.points) {
    json angles = json::object();
    for (std::size_t k = 0; k < p.chain.axes.size(); ++k)
      angles[std::string(1, p.chain.axes[k].letter)] = x.pose.angles_deg[k];
    json j{{"angles_deg", angles},
           {"point_mm", vec_json(x.pose.point_mm)},
           {"nominal_mm", vec_json(x.nominal_mm)},
           {"determined", x.determined}};
    if (x.pose.tool_mm) j["tool_mm"] = vec_json(*x.pose.tool_mm);
    if (x.determined) {
      const Eigen::Vector3d std = x.covariance.diagonal().cwiseMax(0.0).cwiseSqrt();
      json cov = json::array();
      for (int a = 0; a < 3; ++a)
        cov.push_back(
            json::array({r6(x.covariance(a, 0)), r6(x.covariance(a, 1)), r6(x.covariance(a, 2))}));
      j["error_um"] = vec_json(x.error_um);
      j["std_um"] = vec_json(std);
      j["covariance_um2"] = cov;
      j["U_um"] = r6(x.U_um);
      if (x.tool_um) j["tool_um"] = vec_json(*x.tool_um);
      if (x.workpiece_um) j["workpiece_um"] = vec_json(*x.workpiece_um);
    } else {
      j["reason"] =
          "the machine result does not determine every location error this point moves with";
    }
    points.push_back(j);
  }
  json warnings = json::array();
  for (const std::string& w : p.warnings) warnings.push_back(w);
  json out{{"format", kPredictFormat},
           {"inputs", {{"result", p.result_source}, {"poses", p.poses_source}}},
           {"machine", p.machine_name},
           {"body", chain_body_text(p)},
           {"error", chain_error_text(p)},
           {"basis", "location"},
           {"coverage_probability", p.coverage.coverage_probability},
           {"k", p.coverage.k},
           {"k_length", p.coverage.k_length},
           {"dof", nullptr},
           {"points", points},
           {"result_warnings", warnings}};
  if (!p.result_sha256.empty()) out["inputs"]["result_sha256"] = p.result_sha256;
  out["largest"] = nullptr;  // no point determined
  if (const int i = largest_chain_point(p); i >= 0) {
    const ChainPointPrediction& x = p.points[static_cast<std::size_t>(i)];
    out["largest"] = {{"index", i}, {"length_um", r6(x.error_um.norm())}, {"U_um", r6(x.U_um)}};
  }
  return out;
}

std::string chain_prediction_text(const ChainPredictResult& p) {
  std::ostringstream s;
  s << "predict: " << p.points.size() << " point" << (p.points.size() == 1 ? "" : "s")
    << " of machine " << terminal_text(p.machine_name) << " (" << chain_body_text(p) << ") from "
    << terminal_text(p.result_source) << "\n";
  for (const std::string& w : p.warnings)
    s << "Warning (the machine result's; its uncertainties may be too small): " << terminal_text(w)
      << "\n";
  s << "error: " << chain_error_text(p) << "; U: the true error vector lies within U of it with "
    << fmt_num(100 * p.coverage.coverage_probability, 4) << " % (Gaussian)\n";
  auto triple = [](const Eigen::Vector3d& v, int decimals) {
    return "(" + fmt_rounded(v.x(), decimals) + ", " + fmt_rounded(v.y(), decimals) + ", " +
           fmt_rounded(v.z(), decimals) + ")";
  };
  const bool tool = p.order.both();
  s << (tool ? "points and tool tips" : "points")
    << " where they are with every axis at zero; errors in the machine frame\n";
  s << std::setw(22) << "angles deg" << std::setw(26) << "point mm (x, y, z)";
  if (tool) s << std::setw(26) << "tool tip mm (x, y, z)";
  s << std::setw(28) << "error um (x, y, z)" << std::setw(8) << "|e|" << std::setw(7) << "U"
    << "\n";
  for (const ChainPointPrediction& x : p.points) {
    s << std::setw(22) << angles_text(p, x.pose) << std::setw(26) << triple(x.pose.point_mm, 1);
    if (x.pose.tool_mm) s << std::setw(26) << triple(*x.pose.tool_mm, 1);
    if (!x.determined) {
      s << "  not determined: the machine result does not determine every location error it "
           "moves with\n";
      continue;
    }
    s << std::setw(28) << triple(x.error_um, 2) << std::setw(8) << fmt_rounded(x.error_um.norm(), 2)
      << std::setw(7) << fmt_rounded(x.U_um, 2) << "\n";
  }
  if (const int i = largest_chain_point(p); i >= 0) {
    const ChainPointPrediction& x = p.points[static_cast<std::size_t>(i)];
    s << "Largest error: " << fmt_rounded(x.error_um.norm(), 2) << " um (U "
      << fmt_rounded(x.U_um, 2) << " um) at " << angles_text(p, x.pose) << " deg, point "
      << triple(x.pose.point_mm, 1) << " mm";
    if (x.pose.tool_mm) s << ", tool tip " << triple(*x.pose.tool_mm, 1) << " mm";
    s << "\n";
  }
  if (largest_chain_point(p) < 0)
    s << "No point is determined: the machine result leaves a location error every point moves "
         "with undetermined (its axes' results say which).\n";
  else if (tool)
    s << "The tool tip is off the workpiece's point by the error (the tool's and the workpiece's "
         "parts: --out's tool_um, workpiece_um).\n";
  else
    s << "On a table the tool meets the workpiece's point off by minus the error; on a head the "
         "tool tip is off by it.\n";
  return s.str();
}

}  // namespace dbbkit::io
