#pragma once
// The design gate: every design evaluated and compared with a baseline file
// (`dbbkit.designs-baseline/1`); a design whose rank, worst_std_um or (with
// declared set-up tolerances) worst_total_std_um got worse than its baseline by
// more than the tolerance fails; a total without a baseline figure fails too.

#include <map>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

namespace dbbkit::io {

inline constexpr const char* kBaselineFormat = "dbbkit.designs-baseline/1";

struct BenchFigures {
  int rank = 0, n_unknowns = 0;
  std::optional<double> worst_std_um, worst_determined_std_um;
  // With declared set-up tolerances (absent otherwise): the total (noise and set-up).
  std::optional<double> worst_total_std_um, worst_total_determined_std_um;
};

struct Baseline {
  double tolerance_relative = 0;
  std::map<std::string, BenchFigures> designs;  // by file name
};

Baseline read_baseline_file(const std::string& path);
nlohmann::json baseline_to_json(const Baseline& b);

struct BenchRow {
  std::string key, file, name, axis, model;
  BenchFigures now;
  std::optional<double> condition_number;
  std::optional<BenchFigures> baseline;
  std::string status;  // "ok", "improved", "worse", "new"
  std::string detail;
};

// Compares one design's figures with its baseline: status and what changed.
void judge(BenchRow& row, double tolerance_relative);

std::string bench_table(const std::vector<BenchRow>& rows, double tolerance_relative);

}  // namespace dbbkit::io
