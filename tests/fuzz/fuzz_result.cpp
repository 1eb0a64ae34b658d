// libFuzzer target: the result reader of compare and compensation (result_read.hpp), then every
// compensation format and a comparison of the result with itself. Bad input must end in
// InputError; any other exception or a crash is a bug.
#include <cstdint>
#include <string>

#include "dbbkit/error.hpp"
#include "dbbkit/io/compare_io.hpp"
#include "dbbkit/io/compensation_io.hpp"
#include "dbbkit/io/result_read.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  try {
    const dbbkit::io::ResultFile r = dbbkit::io::result_from_text(text, "fuzz");
    for (const auto f :
         {dbbkit::io::CompensationFormat::kIsg, dbbkit::io::CompensationFormat::kTable,
          dbbkit::io::CompensationFormat::kLinuxCnc}) {
      try {
        dbbkit::io::CompensationOptions o;
        o.linuxcnc_kins = "xyzac-trt";
        (void)dbbkit::io::compensation_text(r, f, o);
      } catch (const dbbkit::InputError&) {
      }
    }
    const dbbkit::io::Comparison c = dbbkit::io::compare_results(r, r);
    if (c.significant() != 0) __builtin_trap();  // a result against itself changes nothing
    (void)dbbkit::io::comparison_to_json(c);
    (void)dbbkit::io::comparison_summary(c);
  } catch (const dbbkit::InputError&) {
  }
  return 0;
}
