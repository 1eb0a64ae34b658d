// libFuzzer target: the truth reader, and simulation of the paper's C design from what it accepts.
#include <cstdint>
#include <string>

#include "dbbkit/error.hpp"
#include "dbbkit/io/design_io.hpp"
#include "dbbkit/io/json_reader.hpp"
#include "dbbkit/io/truth_io.hpp"
#include "dbbkit/simulate.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const dbbkit::Design design = [] {
    dbbkit::Design d =
        dbbkit::io::read_design_file(DBBKIT_SOURCE_DIR "/designs/paper-c-turntable.json");
    return d;
  }();
  const std::string text(reinterpret_cast<const char*>(data), size);
  try {
    const dbbkit::Truth t =
        dbbkit::io::truth_from_json(dbbkit::io::parse_json(text, "fuzz"), "fuzz");
    if (t.repeats <= 3) dbbkit::simulate(design, t, 1);
  } catch (const dbbkit::InputError&) {
  }
  return 0;
}
