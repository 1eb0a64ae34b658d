#pragma once
// `dbbkit predict`: the poses a user asks about (a CSV file), one axis' errors as a result states
// them, and the predictions (predict.hpp) as JSON (dbbkit.predict/1) and as text.

#include <nlohmann/json.hpp>
#include <string>
#include <vector>

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
// One pose's checks (the angle within the travel, the point within the length limit); the key
// is `where` followed by the column's name.
void check_pose(const Pose& p, const AxisFrame& axis, const std::string& source,
                const std::string& where);

// The errors of a result's axis; InputError naming the result's key where it lacks what a
// prediction needs (the location errors' covariance: a result of an earlier version).
AxisErrors axis_errors_of(const ResultFile& result);

struct PredictResult {
  std::string result_source, result_sha256, poses_source;
  std::string axis_label;
  char letter = 'C';
  bool location_only = false;
  std::array<std::string, 5> location_names;
  PredictionCoverage coverage;
  std::vector<PointPrediction> points;
  std::vector<std::string> warnings;  // the result's, carried
};

PredictResult predict(const ResultFile& result, const std::vector<Pose>& poses,
                      double coverage_probability, bool location_only = false);

nlohmann::json prediction_to_json(const PredictResult& p);
// `rows`: a line per point (a map over a grid gives its largest errors alone; every point is in
// the JSON).
std::string prediction_text(const PredictResult& p, bool rows = true);

}  // namespace dbbkit::io
