// libFuzzer target: the design reader, and evaluation of the small designs it accepts.
// Bad input must end in InputError; any other exception or a crash is a bug.
#include <cstdint>
#include <string>

#include "dbbkit/error.hpp"
#include "dbbkit/io/design_io.hpp"
#include "dbbkit/io/json_reader.hpp"
#include "dbbkit/observability.hpp"
#include "dbbkit/parameterisation.hpp"

// Evaluation is run only where its work is bounded far below libFuzzer's timeout:
// at most 40 angles and 12 installations, and a series model with
// n_readings * n_unknowns^2 <= 2e6 (order 100 is accepted by the reader).
namespace {
bool bounded(const dbbkit::Design& d) {
  if (d.angles_deg.size() > 40 || d.installations.size() > 12) return false;
  if (d.errors.kind == dbbkit::ErrorModel::Kind::kPerAngle) return true;
  const double p = 6.0 * dbbkit::coefficients_per_error(d.errors);
  return static_cast<double>(d.angles_deg.size() * d.installations.size()) * p * p <= 2e6;
}
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  try {
    const dbbkit::Design d =
        dbbkit::io::design_from_json(dbbkit::io::parse_json(text, "fuzz"), "fuzz");
    if (bounded(d)) {
      const dbbkit::Evaluation ev = dbbkit::evaluate_design(d, 100.0);
      if (ev.worst.worst_std_um && !(*ev.worst.worst_std_um >= 0)) __builtin_trap();
    }
  } catch (const dbbkit::InputError&) {
  }
  return 0;
}
