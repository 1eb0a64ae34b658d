// libFuzzer target: the kit reader, and a bounded search in the small kits it accepts.
// Bad input must end in InputError; any other exception or a crash is a bug.
//
// The search is run only where its work is bounded far below libFuzzer's 10 s timeout,
// whatever the kit says (tests/fuzz/README.md, "Work bound of the kit target"):
//   at most kMaxChoices discrete choices, each searched for at most kMaxEvaluations designs
//   (OptimizeOptions::max_evaluations_per_choice), and for each design a solver work
//   n_readings * n_unknowns^2 <= kMaxWork (series models; a per-angle model is solved per
//   station, n_readings * 36), with n_readings from the most installations the kit's
//   pattern can give; with a spindle in the workspace, whose clash with the table and cup is
//   sampled along the arc (every 0.25 deg on a head, 0.5 deg on a general table), at most
//   kMaxSamples samples over the whole search.
#include <cmath>
#include <cstdint>
#include <string>

#include "dbbkit/error.hpp"
#include "dbbkit/io/kit_io.hpp"
#include "dbbkit/optimize.hpp"
#include "dbbkit/parameterisation.hpp"

namespace {

constexpr size_t kMaxChoices = 8;
constexpr long kMaxEvaluations = 40;
constexpr double kMaxWork = 1e5;
constexpr double kMaxSamples = 2e5;

bool bounded(const dbbkit::Kit& kit) {
  const size_t choices = dbbkit::pattern_choices(kit).size();
  if (choices > kMaxChoices) return false;
  if (kit.workspace && kit.workspace->ball_to_nose_mm > 0) {
    const double per_arc = kit.angle_range_deg.width() / 0.25 + 1;
    const double samples =
        static_cast<double>(choices) * kMaxEvaluations * dbbkit::max_installations(kit) * per_arc;
    if (!(samples <= kMaxSamples)) return false;
  }
  const int per_error = dbbkit::coefficients_per_error(kit.errors);
  for (double step : kit.angle_steps_deg) {
    const double angles = kit.angle_range_deg.width() / step + 1;
    if (!(angles <= 40)) return false;
    const double readings = dbbkit::max_installations(kit) * angles;
    const double unknowns =
        kit.errors.kind == dbbkit::ErrorModel::Kind::kPerAngle ? 6.0 : 6.0 * per_error;
    if (!(readings * unknowns * unknowns <= kMaxWork)) return false;
  }
  return true;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  try {
    const dbbkit::Kit kit = dbbkit::io::kit_from_text(text, "fuzz");
    if (bounded(kit)) {
      dbbkit::OptimizeOptions o;
      o.global_evaluations_per_variable = 3;
      o.local_evaluations = 10;
      o.max_evaluations_per_choice = kMaxEvaluations;
      const dbbkit::OptimizeResult r = dbbkit::optimize_kit(kit, o);
      if (r.evaluations > static_cast<long>(r.choices.size()) * kMaxEvaluations) __builtin_trap();
      if (r.best) {
        if (!r.best->feasible || !(r.best->time_s >= 0)) __builtin_trap();
        if (r.best_evaluation.worst.worst_std_um && !(*r.best_evaluation.worst.worst_std_um >= 0))
          __builtin_trap();
      }
    }
  } catch (const dbbkit::InputError&) {
  }
  return 0;
}
