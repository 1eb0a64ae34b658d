#pragma once
// `dbbkit predict`: the poses a user asks about (a CSV file), one axis' errors as a result states
// them, and the predictions (predict.hpp) as JSON (dbbkit.predict/1) and as text.

#include <functional>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "dbbkit/io/chain_io.hpp"
#include "dbbkit/io/result_read.hpp"
#include "dbbkit/predict.hpp"

namespace dbbkit::io {

inline constexpr const char* kPredictFormat = "dbbkit.predict/1";

// angle_deg,x_mm,y_mm,z_mm (formats.md): a point fixed to the body that turns, body frame, from
// the axis frame's origin; the angle within the axis' travel. InputError naming the line and the
// column otherwise.
std::vector<Pose> parse_poses(const std::string& text, const std::string& source,
                              const AxisFrame& axis);
std::vector<Pose> read_poses_file(const std::string& path, const AxisFrame& axis);
// A poses CSV's rows (either kind): the header exactly `names` in any order (`expected` says
// them in a refusal), then `row(number, where)` for each row, number(column) its cell's value.
// InputError naming the line and column otherwise; at most limits::kMaxPoses rows, at least one.
void for_each_pose_row(const std::string& text, const std::string& source,
                       const std::vector<std::string>& names, const std::string& expected,
                       const std::function<void(const std::function<double(const std::string&)>&,
                                                const std::string&)>& row);
// One pose's checks (the angle within the travel, the point within the length limit); the key
// is `where` followed by the column's name.
void check_pose(const Pose& p, const AxisFrame& axis, const std::string& source,
                const std::string& where);

// The errors of a result's axis; InputError naming the result's key where it lacks what a
// prediction needs (the location errors' covariance: a result of an earlier version).
AxisErrors axis_errors_of(const ResultFile& result);

// A map's parameters as a user gives them (predict --grid-*, Python predict's radii_mm, ...):
// what is not given takes its default (heights {0}, the angles every angle the result measured).
struct GridRequest {
  std::vector<double> radii_mm;
  std::optional<std::vector<double>> heights_mm, angles_deg;
  int around = 8;
};
// The name each parameter goes by in errors.
struct GridKeys {
  std::string radii = "--grid-radius-mm", heights = "--grid-height-mm", around = "--grid-around",
              angles = "--grid-angles-deg";
};
// The map with its defaults filled in, each value checked: every list given has an item and no
// value twice; a radius 0 or within limits::kMinGridRadius_mm..kMaxLength_mm, a height within
// +-kMaxLength_mm and no point farther than kMaxLength_mm from the axis frame's origin, an angle
// within the axis' travel, around 1 to 360, at most limits::kMaxPoses points. InputError naming
// the parameter's key and the item otherwise.
EnvelopeGrid grid_of(const ResultFile& result, const GridRequest& request,
                     const GridKeys& keys = {});
// Numbers separated by commas ("0,100,200"), in decimal notation: InputError naming `key` and
// the item where one is empty or not a finite number.
std::vector<double> parse_number_list(const std::string& text, const std::string& key);

// An angle as the terminal says it: to 0.001 deg, or in full where that would round it (an
// angle not measured must never read as a measured one).
std::string angle_text(double angle_deg);
// "motions" or "location", as the JSON writes a basis.
const char* basis_key(PredictionBasis basis);

struct PredictResult {
  std::string result_source, result_sha256, poses_source;
  std::string axis_label;
  char letter = 'C';
  bool location_only = false;
  std::array<std::string, 5> location_names;
  PredictionCoverage coverage;
  std::vector<PointPrediction> points;
  std::optional<EnvelopeGrid> grid;   // a map's parameters (grid_of); absent for poses
  std::vector<std::string> warnings;  // the result's, carried
};

PredictResult predict(const ResultFile& result, const std::vector<Pose>& poses,
                      double coverage_probability, bool location_only = false);

nlohmann::json prediction_to_json(const PredictResult& p);
// `rows`: a line per point (a map over a grid gives its largest errors alone; every point is in
// the JSON).
std::string prediction_text(const PredictResult& p, bool rows = true);

// A machine result (`dbbkit chain --out`): the poses and the predictions of its chain
// (predict_chain_point).
struct ChainPredictResult {
  std::string result_source, result_sha256, poses_source, machine_name;
  ChainErrors chain;
  ChainOrder order;  // chain_order: on each side the innermost body first
  PredictionCoverage coverage;
  std::vector<ChainPointPrediction> points;
  std::vector<std::string> warnings;  // the machine result's, carried
};

// The chain's errors as a prediction takes them. InputError naming the machine result's key
// where its axes are not one chain on each side (chain_order).
ChainErrors chain_errors_of(const ChainFile& f);
// The poses' columns: <L>_deg for each axis of the chain (in the chain's order; a file may give
// them in any), x_mm,y_mm,z_mm: the point fixed to the innermost body (a table and a head: the
// workpiece's on the innermost table), and for a table and a head tool_x_mm,tool_y_mm,tool_z_mm:
// the tool tip in the innermost head; machine frame with every axis at zero, from its origin.
std::vector<std::string> chain_pose_columns(const ChainErrors& chain);
// One pose from its values in those columns (`value(k)`: columns[k]'s, read in order): mm within
// +-limits::kMaxLength_mm, each angle within +-36000 deg; InputError at "<where>, column <name>"
// otherwise.
ChainPose chain_pose_of(const ChainErrors& chain, const std::vector<std::string>& columns,
                        const std::function<double(std::size_t)>& value, const std::string& source,
                        const std::string& where);
// Those columns (as chain_pose_of), InputError naming the line and column otherwise; at most
// limits::kMaxPoses rows.
std::vector<ChainPose> parse_chain_poses(const std::string& text, const std::string& source,
                                         const ChainErrors& chain);
// `chain`: chain_errors_of(f), as the poses were read against it.
ChainPredictResult predict_chain(const ChainFile& f, ChainErrors chain,
                                 const std::vector<ChainPose>& poses, double coverage_probability);
nlohmann::json chain_prediction_to_json(const ChainPredictResult& p);
std::string chain_prediction_text(const ChainPredictResult& p);

}  // namespace dbbkit::io
