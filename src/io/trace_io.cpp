#include "dbbkit/io/trace_io.hpp"

#include <charconv>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iomanip>

#include "dbbkit/error.hpp"
#include "dbbkit/limits.hpp"
#include "dbbkit/user_text.hpp"

namespace dbbkit::io {

namespace {

std::string_view trim(std::string_view s) {
  const std::size_t a = s.find_first_not_of(" \t\r");
  if (a == std::string_view::npos) return {};
  return s.substr(a, s.find_last_not_of(" \t\r") - a + 1);
}

// The fields of a line: split at `delimiter`, or at runs of spaces and tabs when it is ' '.
void split(std::string_view line, char delimiter, std::vector<std::string_view>& out) {
  out.clear();
  if (delimiter == ' ') {
    std::size_t i = 0;
    while (true) {
      i = line.find_first_not_of(" \t\r", i);
      if (i == std::string_view::npos) return;
      const std::size_t e = std::min(line.find_first_of(" \t\r", i), line.size());
      out.push_back(line.substr(i, e - i));
      i = e;
    }
  }
  std::size_t i = 0;
  while (true) {
    const std::size_t e = line.find(delimiter, i);
    out.push_back(trim(line.substr(i, e == std::string_view::npos ? e : e - i)));
    if (e == std::string_view::npos) return;
    i = e + 1;
  }
}

// A number of a field; `decimal_comma`: a comma is the decimal point. No hex, no inf, no nan.
bool number(std::string_view field, bool decimal_comma, double& x) {
  if (field.empty() || field.size() > 64) return false;
  char buffer[65];
  std::size_t n = 0;
  for (const char c : field) {
    const char d = decimal_comma && c == ',' ? '.' : c;
    if (!((d >= '0' && d <= '9') || d == '.' || d == '-' || d == '+' || d == 'e' || d == 'E'))
      return false;
    buffer[n++] = d;
  }
  const char* begin = buffer + (buffer[0] == '+' ? 1 : 0);
  const auto [end, ec] = std::from_chars(begin, buffer + n, x);
  return ec == std::errc() && end == buffer + n && std::isfinite(x);
}

// The lines of a stream: each ends at LF, CR LF or CR alone (old Mac files), or at the end;
// one longer than limits::kMaxTraceLineBytes is refused there, naming its number, before more
// of it is read.
class Lines {
 public:
  Lines(std::istream& in, const std::string& source) : in_(in), source_(source) {}
  bool next(std::string& line) {
    line.clear();
    bool any = false;
    while (true) {
      if (pos_ == end_ && !fill()) {
        if (any) ++number_;
        return any;
      }
      if (skip_lf_) {
        skip_lf_ = false;
        if (buffer_[pos_] == '\n' && ++pos_ == end_) continue;
      }
      any = true;
      std::size_t i = pos_;
      while (i < end_ && buffer_[i] != '\n' && buffer_[i] != '\r') ++i;
      if (line.size() + (i - pos_) > limits::kMaxTraceLineBytes) {
        throw InputError(source_, "line " + std::to_string(number_ + 1),
                         "longer than " + std::to_string(limits::kMaxTraceLineBytes) +
                             " characters, the longest line a trace may have (README, "
                             "\"Limits\"): not a trace file");
      }
      line.append(buffer_.data() + pos_, i - pos_);
      pos_ = i;
      if (i < end_) {
        skip_lf_ = buffer_[i] == '\r';
        ++pos_;
        ++number_;
        return true;
      }
    }
  }
  long number() const { return number_; }  // of the last line read, from 1

 private:
  bool fill() {
    in_.read(buffer_.data(), static_cast<std::streamsize>(buffer_.size()));
    pos_ = 0;
    end_ = static_cast<std::size_t>(in_.gcount());
    if (end_ == 0 && in_.bad()) throw InputError(source_, "", "cannot read the file");
    if (end_ == 0) return false;
    return true;
  }
  std::istream& in_;
  const std::string& source_;
  std::vector<char> buffer_ = std::vector<char>(std::size_t{1} << 16);
  std::size_t pos_ = 0, end_ = 0;
  long number_ = 0;
  bool skip_lf_ = false;
};

std::string number_text(double x) {
  char b[32];
  std::snprintf(b, sizeof b, "%.9g", x);
  return b;
}

}  // namespace

void parse_trace_columns(const std::string& text, TraceFormat& format) {
  std::vector<std::string_view> parts;
  split(text, ',', parts);
  bool seen_time = false, seen_reading = false;
  for (const std::string_view p : parts) {
    const std::size_t eq = p.find('=');
    const std::string key(trim(p.substr(0, eq)));
    const std::string value(eq == std::string_view::npos ? "" : trim(p.substr(eq + 1)));
    if (eq == std::string_view::npos || value.empty() || (key != "time" && key != "reading")) {
      throw InputError(option_name("--columns"), quote_value(std::string(p)),
                       "expected time=NAME and/or reading=NAME, comma-separated");
    }
    std::string& column = key == "time" ? format.time_column : format.reading_column;
    if ((key == "time" && seen_time) || (key == "reading" && seen_reading))
      throw InputError(option_name("--columns"), key, "given twice");
    (key == "time" ? seen_time : seen_reading) = true;
    column = value;
  }
  if (format.time_column == format.reading_column)
    throw InputError(option_name("--columns"), "", "the time and the reading are one column");
}

Trace parse_trace(std::istream& in, const TraceFormat& format, const std::string& source) {
  if (!format.unit.empty() && format.unit != "um" && format.unit != "mm")
    throw InputError(option_name("--unit"), "",
                     quote_value(format.unit) + " is not a unit of a reading: um or mm");
  if (!format.reading_column.empty() && format.unit.empty()) {
    throw InputError(
        option_name("--unit"), "",
        "the reading column " + quote_value(format.reading_column) + " needs its unit: um or mm");
  }
  if (format.sample_rate_hz && !(*format.sample_rate_hz >= limits::kMinTraceSampleRate_hz &&
                                 *format.sample_rate_hz <= limits::kMaxTraceSampleRate_hz)) {
    throw InputError(option_name("--sample-rate-hz"), "",
                     number_text(*format.sample_rate_hz) + " Hz: must lie in [" +
                         number_text(limits::kMinTraceSampleRate_hz) + ", " +
                         number_text(limits::kMaxTraceSampleRate_hz) + "] Hz");
  }
  Trace trace;
  std::string raw;
  std::vector<std::string_view> fields;
  Lines lines(in, source);
  long line_no = 0, last_line = 0;
  char delimiter = 0;
  bool decimal_comma = false;
  int time_col = -1, reading_col = -1;
  std::size_t columns = 0;
  double factor = 1.0;  // to um
  long row = 0;
  while (lines.next(raw)) {
    line_no = lines.number();
    std::string_view line(raw);
    if (line_no == 1 && line.size() >= 3 && line.substr(0, 3) == "\xEF\xBB\xBF")
      line.remove_prefix(3);
    const std::string_view t = trim(line);
    if (t.empty() || t[0] == '#') continue;
    const std::string where = "line " + std::to_string(line_no);
    if (!delimiter) {  // the header
      delimiter = t.find(';') != std::string_view::npos    ? ';'
                  : t.find('\t') != std::string_view::npos ? '\t'
                  : t.find(',') != std::string_view::npos  ? ','
                                                           : ' ';
      decimal_comma = delimiter != ',';
      split(t, delimiter, fields);
      columns = fields.size();
      std::string names;
      for (std::size_t c = 0; c < fields.size(); ++c) {
        const std::string_view f = fields[c];
        names += (c ? ", " : "") + quote_value(std::string(f));
        auto take = [&](int& col, const char* what) {
          if (col >= 0)
            throw InputError(source, where, std::string("two ") + what + " columns in the header");
          col = static_cast<int>(c);
        };
        if (f == format.time_column) take(time_col, "time");
        if (format.reading_column.empty()) {
          if (f == "reading_um" || f == "reading_mm") {
            take(reading_col, "reading");
            factor = f == "reading_mm" ? 1000.0 : 1.0;
          }
        } else if (f == format.reading_column) {
          take(reading_col, "reading");
          factor = format.unit == "mm" ? 1000.0 : 1.0;
        }
      }
      if (reading_col < 0) {
        throw InputError(
            source, where,
            "no reading column (" +
                (format.reading_column.empty() ? std::string("reading_um or reading_mm")
                                               : quote_value(format.reading_column)) +
                ") among " + names + "; name another with " +
                option_with_value("--columns", "reading=NAME") + " and " +
                option_with_value("--unit", "um|mm"));
      }
      if (time_col < 0 && format.sample_rate_hz && format.time_column != "time_s") {
        throw InputError(source, where,
                         "no time column " + quote_value(format.time_column) + " among " + names +
                             " (" + option_with_value("--columns", "time=...") +
                             "); without it, give " + option_name("--sample-rate-hz") +
                             " alone and the rows are counted");
      }
      if (time_col < 0 && !format.sample_rate_hz) {
        throw InputError(source, where,
                         "no time column " + quote_value(format.time_column) + " among " + names +
                             "; name it with " + option_with_value("--columns", "time=NAME") +
                             ", or give " + option_name("--sample-rate-hz"));
      }
      // Two clocks: a column of seconds by its name, and a rate that would read it as a sample
      // index (the seconds divided by the rate once more).
      if (time_col >= 0 && format.sample_rate_hz && format.time_column == "time_s") {
        throw InputError(source, where,
                         "the column time_s holds seconds, and " + option_name("--sample-rate-hz") +
                             " would read it as a sample index: one clock, not two. Leave out " +
                             option_name("--sample-rate-hz") +
                             " (the seconds of time_s are the clock), or name a sample index "
                             "column with " +
                             option_with_value("--columns", "time=NAME"));
      }
      trace.reading_column = std::string(fields[static_cast<std::size_t>(reading_col)]);
      trace.reading_unit = factor == 1.0 ? "um" : "mm";
      continue;
    }
    split(t, delimiter, fields);
    if (fields.size() != columns) {
      throw InputError(source, where,
                       "expected " + std::to_string(columns) + " fields, found " +
                           std::to_string(fields.size()));
    }
    double x = 0, time = 0;
    if (!number(fields[static_cast<std::size_t>(reading_col)], decimal_comma, x)) {
      throw InputError(source, where,
                       quote_value(std::string(fields[static_cast<std::size_t>(reading_col)])) +
                           " is not a reading");
    }
    if (time_col >= 0) {
      if (!number(fields[static_cast<std::size_t>(time_col)], decimal_comma, time)) {
        throw InputError(source, where,
                         quote_value(std::string(fields[static_cast<std::size_t>(time_col)])) +
                             " is not a time");
      }
      if (format.sample_rate_hz) {
        // A sample index counts samples: a fraction is a time in seconds, not an index.
        if (time != std::floor(time)) {
          throw InputError(
              source, where + ", column " + quote_value(format.time_column),
              quote_value(std::string(fields[static_cast<std::size_t>(time_col)])) +
                  " is no sample index (a whole number), which " + option_name("--sample-rate-hz") +
                  " makes of the time column: is it a time in seconds? Then leave out " +
                  option_name("--sample-rate-hz"));
        }
        time /= *format.sample_rate_hz;
      }
      if (!std::isfinite(time)) {
        throw InputError(source, where,
                         quote_value(std::string(fields[static_cast<std::size_t>(time_col)])) +
                             " is not a time at " + number_text(*format.sample_rate_hz) + " Hz");
      }
    } else {
      time = static_cast<double>(row) / *format.sample_rate_hz;
    }
    if (!(std::abs(factor * x) <= limits::kMaxTraceReading_um)) {
      throw InputError(
          source, where,
          "the reading " + quote_value(std::string(fields[static_cast<std::size_t>(reading_col)])) +
              (factor == 1.0 ? " um" : " mm") + " is beyond the limit of a reading (+-" +
              number_text(limits::kMaxTraceReading_um) +
              " um, README \"Limits\"); check the unit (" + option_name("--unit") + ")");
    }
    if (!trace.time_s.empty() && !(time > trace.time_s.back())) {
      throw InputError(source, where,
                       "the time does not increase (" + number_text(time) + " s after " +
                           number_text(trace.time_s.back()) + " s)");
    }
    if (trace.time_s.size() >= kMaxTraceSamples) {
      throw InputError(source, where,
                       "more than " + std::to_string(kMaxTraceSamples) +
                           " samples, the most one trace may hold (docs/formats.md, \"Limits\")");
    }
    // A new run of lines; the last run kept holds line 0 (not known from there on).
    if ((trace.line_runs.empty() || line_no != last_line + 1) &&
        (trace.line_runs.empty() || trace.line_runs.back().second != 0)) {
      trace.line_runs.emplace_back(trace.time_s.size(),
                                   trace.line_runs.size() + 1 < Trace::kMaxLineRuns ? line_no : 0);
    }
    last_line = line_no;
    trace.time_s.push_back(time);
    trace.reading_um.push_back(factor * x);
    ++row;
  }
  if (!delimiter) throw InputError(source, "", "no header row (only comments or blank lines)");
  if (trace.time_s.empty()) throw InputError(source, "", "no samples after the header row");
  return trace;
}

Trace read_trace_file(const std::string& path, const TraceFormat& format) {
  std::error_code ec;
  const std::filesystem::file_status st = std::filesystem::status(path, ec);
  if (std::filesystem::is_directory(st))
    throw InputError(path, "", "a directory, not a trace file");
  if (std::filesystem::exists(st) && !std::filesystem::is_regular_file(st)) {
    throw InputError(path, "",
                     "not a regular file (a device, a pipe or a socket): a trace is read from a "
                     "file");
  }
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path, "", "cannot open the file");
  return parse_trace(in, format, path);
}

void write_trace_csv(std::ostream& out, const Trace& trace,
                     const std::vector<std::string>& comments) {
  // A comment is one line whatever it quotes (a design's name from its file).
  for (const std::string& c : comments) out << "# " << printable(c, 400) << "\n";
  out << "time_s,reading_um\n";
  // Times to the microsecond, the reader's closest samples (at 0.1 ms, a trace above 10 kHz had
  // times that repeat, and one at 7 kHz intervals off by a third).
  char buffer[64];
  for (std::size_t i = 0; i < trace.time_s.size(); ++i) {
    const int n =
        std::snprintf(buffer, sizeof buffer, "%.6f,%.4f\n", trace.time_s[i], trace.reading_um[i]);
    out.write(buffer, n);
  }
}

}  // namespace dbbkit::io
