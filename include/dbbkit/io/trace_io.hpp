#pragma once
// Raw traces as delimited text (formats: "Raw traces"): `#` comment lines, a header row, then
// one sample a row. The delimiter is the header's: a semicolon, a tab, a comma, or else spaces;
// with a delimiter other than the comma a decimal comma is read as a decimal point. The header
// names the time column (time_s) and the reading column (reading_um or reading_mm); other
// columns are ignored. Vendor exports map through TraceFormat (the command line's --columns,
// --unit, --sample-rate-hz).

#include <optional>
#include <string>
#include <vector>

#include "dbbkit/limits.hpp"
#include "dbbkit/trace.hpp"

namespace dbbkit::io {

struct TraceFormat {
  std::string time_column = "time_s";
  // Empty: reading_um or reading_mm by the header; else this column, in `unit`.
  std::string reading_column;
  std::string unit;  // "um" or "mm" for reading_column
  // With a sample rate the time is the time column's value (a sample index) divided by it, or,
  // without such a column, the row's number (from 0) divided by it.
  std::optional<double> sample_rate_hz;
};

// The most samples one trace may hold (limits.hpp; docs/formats.md, "Limits").
inline constexpr std::size_t kMaxTraceSamples = limits::kMaxTraceSamples;

// --columns time=NAME,reading=NAME into `format`; throws InputError("--columns", ...).
void parse_trace_columns(const std::string& text, TraceFormat& format);

// Throws InputError(path, "line N", ...) naming what is wrong; a directory or another file that
// is not a regular one is refused as such. A line ends at LF, CR LF or CR alone.
Trace read_trace_file(const std::string& path, const TraceFormat& format);
Trace parse_trace(std::istream& in, const TraceFormat& format, const std::string& source);

// A trace as the reader reads it back (time_s, reading_um; comment lines first).
void write_trace_csv(std::ostream& out, const Trace& trace,
                     const std::vector<std::string>& comments);

}  // namespace dbbkit::io
