// libFuzzer target: the measurement CSV reader, validated against the paper's C design,
// and identification of what it accepts; the same bytes as a raw trace (reader and dwells).
#include <cstdint>
#include <sstream>
#include <string>

#include "dbbkit/error.hpp"
#include "dbbkit/identify.hpp"
#include "dbbkit/io/design_io.hpp"
#include "dbbkit/io/measurement_io.hpp"
#include "dbbkit/io/trace_io.hpp"
#include "dbbkit/trace.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const dbbkit::Design design =
      dbbkit::io::read_design_file(DBBKIT_SOURCE_DIR "/designs/paper-c-turntable.json");
  const std::string text(reinterpret_cast<const char*>(data), size);
  try {
    const auto readings = dbbkit::io::parse_measurements(text, "fuzz");
    dbbkit::validate_readings(design, readings, "fuzz");
    dbbkit::IdentifyOptions
        options;  // the error motion values' Monte Carlo, bounded for the fuzzer's time limit
    options.iso_motion.max_trials = 20000;
    const dbbkit::IdentifyResult r = dbbkit::identify(design, readings, options);
    if (!(r.estimate.chi2 >= 0)) __builtin_trap();
  } catch (const dbbkit::InputError&) {
  }
  try {
    std::istringstream in(text);
    const dbbkit::Trace trace = dbbkit::io::parse_trace(in, {}, "fuzz");
    const dbbkit::TraceReadings r = dbbkit::readings_from_trace(
        design, "1r", trace, {dbbkit::Sweep::kCCW, dbbkit::Sweep::kCW}, {}, "fuzz");
    for (const dbbkit::Reading& g : r.readings)
      if (!(*g.std_um >= 0) || *g.samples < 1) __builtin_trap();
  } catch (const dbbkit::InputError&) {
  }
  return 0;
}
