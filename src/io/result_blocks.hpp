#pragma once
// The blocks the result writers share (formats.md "Keys every result JSON carries"): internal to
// the library's writers (the installed result_io.hpp writes whole results).

#include <cmath>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "dbbkit/io/result_io.hpp"

namespace dbbkit::io {

// What every result carries first: format, version, input files, design, noise.
nlohmann::json result_header(const std::string& format, const Design& design,
                             const InputFiles& inputs);
// status, message, n_readings, n_unknowns, rank, condition_number, condition_scaling.
void add_rank_block(nlohmann::json& j, const Estimate& est);

// The effects fitted with the errors (identify --effects): JSON (label, value and std by
// parameter, unit) and terminal lines (empty without effects).
nlohmann::json fitted_effects_to_json(const std::vector<FittedEffect>& effects);

// A value as written to the result files: to 1e-6 of its unit (pm, prad), far below any
// uncertainty (+ 0.0: a value rounding to zero is 0, never -0).
inline double r6(double x) { return std::round(x * 1e6) / 1e6 + 0.0; }

// A number, or null when absent (a value that cannot be computed is never a number).
nlohmann::json optional_number(const std::optional<double>& x);
// The residual block {rms_um, chi2, dof, p_value}.
nlohmann::json residual_to_json(const Estimate& est);

// The set-up tolerances of every installation.
nlohmann::json setup_tolerances_to_json(const Design& design);

// The errors block (value and std per angle, null where not determined); with
// values = false only the std is written (a-priori evaluation).
nlohmann::json errors_to_json(const std::vector<ErrorsAtAngle>& errors, bool values);
nlohmann::json unidentifiable_to_json(const std::vector<Unidentifiable>& list);

// {"topic", "text"} per item.
nlohmann::json brief_to_json(const std::vector<BriefItem>& brief);

}  // namespace dbbkit::io
