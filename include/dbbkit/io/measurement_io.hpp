#pragma once
// Reader and writer of measurement files: CSV, one reading per row (formats.md).
// Required columns: installation, angle_deg, and exactly one of reading_mm /
// reading_um. Optional: time_s, sweep (cw | ccw), repeat. An empty optional
// cell means "not recorded" for that row; unknown columns are an error.

#include <ostream>
#include <string>
#include <vector>

#include "dbbkit/design.hpp"
#include "dbbkit/measurement.hpp"

namespace dbbkit::io {

// Parses the CSV text; throws InputError(source, "line N", ...). Does not check against a design.
// A header with a column "sphere" is a touch probe's file (below).
std::vector<Reading> parse_measurements(const std::string& text, const std::string& source);

// Reads a file and validates it against the design.
std::vector<Reading> read_measurement_file(const std::string& path, const Design& design);

// Writes readings with reading_um (and the optional columns any reading has).
void write_measurements_csv(std::ostream& out, const std::vector<Reading>& readings);
// The same in the design's instrument's form: a probe's, one row per sphere, angle and repeat.
void write_measurements_csv(std::ostream& out, const std::vector<Reading>& readings,
                            const Design& design);

// A touch probe's file (formats.md, "A second instrument"): sphere,angle_deg,dx_um,dy_um,dz_um
// [,repeat], one row per sphere, angle and repeat, each row three readings of the sphere's
// channels (instrument.hpp, probe_channel_id). probe_measurement_header: whether a header row's
// cells are a probe's.
bool probe_measurement_header(const std::vector<std::string>& header);
void write_probe_measurements_csv(std::ostream& out, const Design& design,
                                  const std::vector<Reading>& readings);

}  // namespace dbbkit::io
