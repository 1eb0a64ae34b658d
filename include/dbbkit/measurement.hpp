#pragma once
// DBB readings as measured: one per row of a measurement file (formats.md).

#include <optional>
#include <string>
#include <vector>

#include "dbbkit/design.hpp"

namespace dbbkit {

enum class Sweep { kCW, kCCW };

// "cw" or "ccw", as measurement files write it.
const char* sweep_name(Sweep s);

struct Reading {
  std::string installation;  // an id of the design
  double angle_deg = 0.0;
  double reading_um = 0.0;       // bar length change
  std::optional<double> time_s;  // absent: not recorded
  std::optional<Sweep> sweep;
  std::optional<int> repeat;
  // From a trace (dbbkit readings): the scatter of the samples averaged and their number.
  std::optional<double> std_um;
  std::optional<int> samples;
  // The Type A standard uncertainty of the reading (the mean) from its dwell's repeatability and
  // its degrees of freedom: batch means of 0.1 s, u = their scatter / sqrt(batches), batches - 1.
  std::optional<double> u_a_um;
  std::optional<int> u_a_dof;
  int line = 0;        // line in the source file (0: not from a file)
  bool in_mm = false;  // read from a reading_mm column (for the message of a unit mix-up)
};

// The largest instrument range a design may declare (instrument.range_mm): no DBB
// reads a length change of 10 mm.
inline constexpr double kMaxAbsReading_um = 10000.0;

// The readings a design would take: one per installation and angle, no time, sweep or
// repeat (so drift and reversal need real data).
std::vector<Reading> nominal_readings(const Design& design);

// Checks readings against a design: the installation exists, the angle is a
// position of the design, values are finite and within the instrument's range
// (design.instrument_range_mm). Throws InputError(source, "line N", ...).
void validate_readings(const Design& design, const std::vector<Reading>& readings,
                       const std::string& source);

}  // namespace dbbkit
