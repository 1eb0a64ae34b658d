#pragma once
// `dbbkit verify`: a result against a test it was not fitted to (verify.hpp), as JSON
// (dbbkit.verify/1) and as text.

#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "dbbkit/io/result_read.hpp"
#include "dbbkit/verify.hpp"

namespace dbbkit::io {

inline constexpr const char* kVerifyFormat = "dbbkit.verify/1";

struct VerifyReport {
  std::string result_source, result_sha256, design_source, data_source;
  std::string axis_label, design_name;
  char letter = 'C';
  std::array<std::string, 5> location_names;
  std::array<std::string, 5> location_units;
  bool location_only = false;
  double k = 2;  // the normal quantile of the coverage probability (a change's U)
  std::optional<double> result_dof;  // the result's Type A degrees of freedom, where stated
  Verification v;
  std::vector<Reading> readings;      // as given (installation, angle, line)
  std::vector<std::string> warnings;  // the result's, carried
  // The installations whose instrument counts the other way (reading_sign -1): their readings,
  // read and predicted, are in that count.
  std::vector<std::string> reversed;
  // What the verdict should be read with: the test's readings are the result's own, or the
  // statistic lies so low (p > 0.999) that the uncertainties may be overstated.
  std::vector<std::string> notes;
};

// InputError (the design's file, axis or machine) where the test is not of the result's axis or
// its frame's origin is not the result's.
void check_test_axis(const ResultFile& result, const Design& design,
                     const std::string& design_source);

// InputError naming the file and key where the result cannot predict the test: the result's
// axis is not the design's (or the machines' frames differ), it does not determine every location
// error, it lacks the covariances a prediction needs (axis_errors_of), more readings than
// limits::kMaxVerifyReadings, or the test's constant parts take up every reading.
VerifyReport verify(const ResultFile& result, const Design& design,
                    const std::vector<Reading>& readings, const std::string& design_source,
                    const std::string& data_source, double coverage_probability,
                    bool location_only = false);

nlohmann::json verification_to_json(const VerifyReport& r);
std::string verification_text(const VerifyReport& r);

// `dbbkit predict --design K`: the test's readings predicted before it is run
// (predict_test_readings), in dbbkit.predict/1 with `readings` instead of `points`.
struct TestPrediction {
  std::string result_source, result_sha256, design_source;
  std::string axis_label, design_name;
  char letter = 'C';
  bool location_only = false;
  double k = 2;  // the normal quantile of the coverage probability
  std::optional<double> result_dof;
  PredictedTest p;
  std::vector<std::string> warnings;  // the result's, carried
  std::vector<std::string> reversed;  // installations of reading_sign -1 (VerifyReport's)
};

// InputError as verify's (the test's axis or machine, a location error not determined, more
// readings than limits::kMaxVerifyReadings).
TestPrediction predict_test(const ResultFile& result, const Design& design,
                            const std::string& design_source, double coverage_probability,
                            bool location_only = false);
nlohmann::json test_prediction_to_json(const TestPrediction& t);
std::string test_prediction_text(const TestPrediction& t);

}  // namespace dbbkit::io
