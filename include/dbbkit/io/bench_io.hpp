#pragma once
// The design gate: every design evaluated and compared with a baseline file
// (`dbbkit.designs-baseline/1`); a design whose rank, worst_std_um or (with
// declared set-up tolerances) worst_total_std_um got worse than its baseline by
// more than the tolerance fails; a total without a baseline figure fails too.

#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

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

// One check of a design, as a CI system reports it (a JUnit test case): "baseline" (the
// comparison with the baseline file) and each absolute limit given.
struct BenchCheck {
  std::string name;  // "baseline", "max_worst_std_um", "max_worst_total_std_um", "max_time_s"
  bool passed = true;
  std::string message;  // what was compared, and why it failed
};

// A design's figures against its baseline (judge): within the tolerance, better, worse, or no
// baseline recorded.
enum class BenchState { kOk, kImproved, kWorse, kNew };
// "ok", "improved", "worse", "new".
const char* bench_state_name(BenchState s);

struct BenchRow {
  std::string key, file, name, axis, model;
  BenchFigures now;
  std::optional<double> condition_number;
  std::optional<double> time_s;  // the design's predicted measurement time, when it states one
  std::optional<BenchFigures> baseline;
  BenchState state = BenchState::kNew;
  std::string detail;
  std::vector<BenchCheck> checks;
  bool passed() const;
};

// Compares one design's figures with its baseline: status and what changed.
void judge(BenchRow& row, double tolerance_relative);

// The gate's checks of one judged row: the baseline (a design without one fails unless
// allow_new) and the absolute limits given.
struct BenchLimits {
  bool allow_new = false;
  std::optional<double> max_worst_std_um, max_worst_total_std_um, max_time_s;
};
void check_row(BenchRow& row, const BenchLimits& limits);

std::string bench_table(const std::vector<BenchRow>& rows, double tolerance_relative);
// The same as a Markdown summary, and as JUnit XML (one test suite, one test case per
// design and check; a failed check carries a <failure> with its message).
std::string bench_markdown(const std::vector<BenchRow>& rows, double tolerance_relative,
                           const BenchLimits& limits);
std::string bench_junit(const std::vector<BenchRow>& rows);

}  // namespace dbbkit::io
