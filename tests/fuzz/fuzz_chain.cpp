// libFuzzer target: the machine result's reader of compensation (chain_io.hpp), then every
// compensation format of a machine. Bad input must end in InputError; any other exception or a
// crash is a bug.
#include <cstdint>
#include <string>

#include "dbbkit/error.hpp"
#include "dbbkit/io/chain_io.hpp"
#include "dbbkit/io/compensation_io.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  try {
    const dbbkit::io::ChainFile m = dbbkit::io::chain_from_text(text, "fuzz");
    for (const auto f :
         {dbbkit::io::CompensationFormat::kIsg, dbbkit::io::CompensationFormat::kTable,
          dbbkit::io::CompensationFormat::kLinuxCnc, dbbkit::io::CompensationFormat::kSiemens}) {
      try {
        dbbkit::io::CompensationOptions o;
        if (f == dbbkit::io::CompensationFormat::kSiemens) o.record = 1;
        if (f == dbbkit::io::CompensationFormat::kLinuxCnc)
          o.current_mm = {{"x-rot-point", 0}, {"y-rot-point", 0}, {"z-rot-point", 0},
                          {"x-offset", 0},    {"y-offset", 0},    {"z-offset", 0}};
        (void)dbbkit::io::machine_compensation_text(m, f, o);
      } catch (const dbbkit::InputError&) {
      }
    }
  } catch (const dbbkit::InputError&) {
  }
  return 0;
}
