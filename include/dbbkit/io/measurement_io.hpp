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
std::vector<Reading> parse_measurements(const std::string& text, const std::string& source);

// Reads a file and validates it against the design.
std::vector<Reading> read_measurement_file(const std::string& path, const Design& design);

// Writes readings with reading_um (and the optional columns any reading has).
void write_measurements_csv(std::ostream& out, const std::vector<Reading>& readings);

}  // namespace dbbkit::io
