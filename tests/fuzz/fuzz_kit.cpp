// libFuzzer target: the kit reader, and a short search in the small kits it accepts.
// Bad input must end in InputError; any other exception or a crash is a bug.
#include <cmath>
#include <cstdint>
#include <string>

#include "dbbkit/error.hpp"
#include "dbbkit/io/kit_io.hpp"
#include "dbbkit/optimize.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  try {
    const dbbkit::Kit kit = dbbkit::io::kit_from_text(text, "fuzz");
    bool small = dbbkit::pattern_choices(kit).size() <= 8;
    for (double step : kit.angle_steps_deg) small = small && kit.angle_range_deg.width() / step <= 40;
    if (small) {
      dbbkit::OptimizeOptions o;
      o.global_evaluations_per_variable = 3;
      o.local_evaluations = 10;
      const dbbkit::OptimizeResult r = dbbkit::optimize_kit(kit, o);
      if (r.best) {
        if (!r.best->feasible || !(r.best->time_s >= 0)) __builtin_trap();
        if (r.best_evaluation.worst.worst_std_um && !(*r.best_evaluation.worst.worst_std_um >= 0)) __builtin_trap();
      }
    }
  } catch (const dbbkit::InputError&) {
  }
  return 0;
}
