// libFuzzer target: the raw trace reader under each of its mappings (the first byte picks the
// columns, the unit and a sample rate), then the dwells found and matched to the paper's C
// design's stops in each of the program's sweeps.
#include <cstdint>
#include <sstream>
#include <string>

#include "dbbkit/error.hpp"
#include "dbbkit/io/design_io.hpp"
#include "dbbkit/io/trace_io.hpp"
#include "dbbkit/trace.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const dbbkit::Design design =
      dbbkit::io::read_design_file(DBBKIT_SOURCE_DIR "/designs/paper-c-turntable.json");
  if (size == 0) return 0;
  const std::uint8_t mode = data[0];
  const std::string text(reinterpret_cast<const char*>(data + 1), size - 1);
  dbbkit::io::TraceFormat format;
  try {
    if (mode & 1) dbbkit::io::parse_trace_columns("time=Sample,reading=Deviation", format);
    if (mode & 2) format.unit = mode & 4 ? "mm" : "um";
    if (mode & 8) format.sample_rate_hz = mode & 16 ? 100.0 : 1e-3;
    std::istringstream in(text);
    const dbbkit::Trace trace = dbbkit::io::parse_trace(in, format, "fuzz");
    if (trace.time_s.size() != trace.reading_um.size() || trace.time_s.empty()) __builtin_trap();
    const char* sweeps = mode & 32 ? "both" : mode & 64 ? "cw" : "ccw";
    dbbkit::DwellOptions options;
    options.dwell_s = mode & 128 ? 0.5 : 2.0;
    const dbbkit::TraceReadings r = dbbkit::readings_from_trace(
        design, "1r", trace, dbbkit::sweeps_by_name(sweeps, "fuzz"), options, "fuzz");
    for (const dbbkit::Reading& g : r.readings)
      if (!(*g.std_um >= 0) || *g.samples < 1 || !(*g.time_s >= trace.time_s.front()))
        __builtin_trap();
  } catch (const dbbkit::InputError&) {
  }
  return 0;
}
