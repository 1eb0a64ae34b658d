#pragma once
// Reader of tolerance files, format `dbbkit.tolerances/1` (README, "Tolerance file"),
// and the conformance decisions as JSON and text (conformance.hpp).

#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "dbbkit/conformance.hpp"

namespace dbbkit::io {

inline constexpr const char* kTolerancesFormat = "dbbkit.tolerances/1";

std::vector<Tolerance> read_tolerances_file(const std::string& path);
std::vector<Tolerance> tolerances_from_json(const nlohmann::json& j, const std::string& source);
// Said once when the file used the alias with the letter O ("XOC"); empty otherwise.
std::string conformance_alias_note(const ConformanceReport& report);

nlohmann::json conformance_to_json(const ConformanceReport& report,
                                   const std::string& tolerances_path);
std::string conformance_text(const ConformanceReport& report);
// One line for the terminal when the decisions go to a file: the verdict and where they are.
std::string conformance_line(const ConformanceReport& report, const std::string& tolerances_path);

// The decision rule (ISO 14253-1 at the report's coverage), the warnings, and the basis of a
// decision (with why an error motion value it needed was not computed), in words.
std::string conformance_rule(const ConformanceReport& report);
std::vector<std::string> conformance_warnings(const ConformanceReport& report);
std::string conformance_basis(const ConformanceReport& report, const ConformanceResult& r);

}  // namespace dbbkit::io
