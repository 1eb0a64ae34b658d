// libFuzzer target: the design reader, and evaluation of the small designs it accepts.
// Bad input must end in InputError; any other exception or a crash is a bug.
#include <cstdint>
#include <string>

#include "dbbkit/error.hpp"
#include "dbbkit/io/design_io.hpp"
#include "dbbkit/observability.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  try {
    const dbbkit::Design d = dbbkit::io::design_from_json(dbbkit::io::parse_json(text, "fuzz"), "fuzz");
    if (d.angles_deg.size() <= 40 && d.installations.size() <= 12) {
      const dbbkit::Evaluation ev = dbbkit::evaluate_design(d, 100.0);
      if (ev.worst.worst_std_um && !(*ev.worst.worst_std_um >= 0)) __builtin_trap();
    }
  } catch (const dbbkit::InputError&) {
  }
  return 0;
}
