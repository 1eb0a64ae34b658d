#pragma once
// Result of `diagnose` (`dbbkit.diagnose/1`), its terminal summary and a
// self-contained HTML report.

#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "dbbkit/diagnose.hpp"
#include "dbbkit/io/result_io.hpp"

namespace dbbkit::io {

// `readings`: the readings given to diagnose (the result's rows index them).
// What the uncertainty of diagnose's ISO quantities holds.
std::string diagnose_iso_note(const DiagnoseResult& r);
nlohmann::json diagnose_to_json(const Design& design, const std::vector<Reading>& readings,
                                const DiagnoseResult& result, const InputFiles& inputs);
std::string diagnose_summary(const Design& design, const std::vector<Reading>& readings,
                             const DiagnoseResult& result);

}  // namespace dbbkit::io
