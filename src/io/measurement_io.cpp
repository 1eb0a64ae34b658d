#include "dbbkit/io/measurement_io.hpp"

#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <iomanip>
#include <map>
#include <sstream>

#include "csv_cells.hpp"
#include "dbbkit/error.hpp"
#include "dbbkit/instrument.hpp"
#include "dbbkit/io/json_reader.hpp"
#include "dbbkit/limits.hpp"
#include "dbbkit/user_text.hpp"

namespace dbbkit::io {

namespace {

using csv::Cell;
using csv::split;
using csv::trim;

const std::vector<std::string> kKnownColumns = {
    "installation", "angle_deg", "reading_mm", "reading_um", "time_s", "sweep",
    "repeat",       "std_um",    "samples",    "u_a_um",     "u_a_dof"};
// A touch probe's file (formats.md, "A second instrument"): each row three readings, one a
// channel of the sphere (instrument.hpp).
const std::vector<std::string> kProbeColumns = {"sphere", "angle_deg", "dx_um",
                                                "dy_um",  "dz_um",     "repeat"};
constexpr const char* kProbeValueColumns[3] = {"dx_um", "dy_um", "dz_um"};

}  // namespace

namespace {

// parse_measurements, saying whether the header was a probe's.
std::vector<Reading> parse(const std::string& text, const std::string& source, bool& probe) {
  // LF, CR LF or a CR alone (an old Mac's files) ends a line.
  std::istringstream in(csv::lf_lines(text));
  std::string raw;
  int line_no = 0;
  std::map<std::string, int> col;
  std::vector<std::string> header;
  std::vector<Reading> readings;
  probe = false;  // a probe's header (probe_measurement_header)
  while (std::getline(in, raw)) {
    ++line_no;
    if (!raw.empty() && raw.back() == '\r') raw.pop_back();
    if (line_no == 1 && raw.size() >= 3 && raw.compare(0, 3, "\xEF\xBB\xBF") == 0) raw.erase(0, 3);
    if (trim(raw).empty()) continue;  // blank lines carry nothing
    const std::string where = "line " + std::to_string(line_no);
    if (header.empty()) {
      // A JSON file given as the data (a design, a result): its first character says so.
      const char first = trim(raw)[0];
      if (first == '{' || first == '[') {
        throw InputError(source, where,
                         "this looks like JSON, not a CSV measurement file (a header row such as "
                         "installation,angle_deg,reading_mm, then one reading a row; "
                         "docs/formats.md): is a design or a result given as the data?");
      }
    }
    if (raw.find('"') != std::string::npos) {
      throw InputError(source, where,
                       "quoted fields are not supported (ids and numbers need no quotes)");
    }
    std::vector<std::string> cells = split(raw);
    if (header.empty()) {
      probe = probe_measurement_header(cells);
      header = cells;
      for (size_t i = 0; i < header.size(); ++i) {
        const std::string& h = header[i];
        bool known = false;
        for (const auto& k : probe ? kProbeColumns : kKnownColumns) known = known || k == h;
        if (!known && probe)
          throw InputError(source, where,
                           "unknown column " + quote_value(h) +
                               " in a probe's file (expected sphere, angle_deg, dx_um, dy_um, "
                               "dz_um and optionally repeat)");
        if (!known && (h == "dx_um" || h == "dy_um" || h == "dz_um"))
          throw InputError(source, where,
                           "column " + quote_value(h) +
                               " is a touch probe's: its file has the column sphere too "
                               "(sphere,angle_deg,dx_um,dy_um,dz_um[,repeat])");
        if (!known) {
          // Another delimiter (a spreadsheet's export in a locale whose lists use ';'): one
          // column named by the whole header.
          for (const auto& [c, name] : {std::pair<char, const char*>{';', "';'"}, {'\t', "tabs"}}) {
            if (h.find(c) != std::string::npos) {
              throw InputError(source, where,
                               std::string("the delimiter is ','; this header uses ") + name +
                                   " (" + quote_value(h) +
                                   "): write the file comma-separated, with '.' as the decimal "
                                   "point");
            }
          }
          throw InputError(
              source, where,
              "unknown column " + quote_value(h) +
                  " (expected installation, angle_deg, reading_mm or reading_um, "
                  "and optionally time_s, sweep, repeat, std_um, samples, u_a_um, u_a_dof)");
        }
        if (!col.emplace(h, static_cast<int>(i)).second)
          throw InputError(source, where, "column " + quote_value(h) + " appears twice");
      }
      if (probe) {
        for (const char* req : {"sphere", "angle_deg", "dx_um", "dy_um", "dz_um"})
          if (!col.count(req))
            throw InputError(source, where,
                             std::string("required column '") + req + "' is missing");
        continue;
      }
      for (const char* req : {"installation", "angle_deg"}) {
        if (!col.count(req))
          throw InputError(source, where, std::string("required column '") + req + "' is missing");
      }
      const bool mm = col.count("reading_mm"), um = col.count("reading_um");
      if (!mm && !um)
        throw InputError(source, where, "a column reading_mm or reading_um is required");
      if (mm && um) throw InputError(source, where, "both reading_mm and reading_um: give one");
      continue;
    }
    if (cells.size() != header.size()) {
      throw InputError(source, where,
                       "expected " + std::to_string(header.size()) + " fields, found " +
                           std::to_string(cells.size()));
    }
    auto cell = [&](const std::string& name) {
      return Cell{source, line_no, name, cells[col.at(name)]};
    };
    auto present = [&](const std::string& name) {
      return col.count(name) && !cells[col.at(name)].empty();
    };
    if (probe) {
      const std::string& sphere = cells[col.at("sphere")];
      if (sphere.empty()) cell("sphere").fail("empty sphere id");
      Reading r;
      r.line = line_no;
      r.angle_deg = cell("angle_deg").number();
      if (present("repeat")) r.repeat = cell("repeat").integer();
      if (readings.size() + 3 > limits::kMaxReadings)
        throw InputError(source, where,
                         "more than " + std::to_string(limits::kMaxReadings) +
                             " readings (three a row), the most one file may hold "
                             "(docs/formats.md, \"Limits\")");
      for (int k = 0; k < 3; ++k) {
        r.installation = probe_channel_id(sphere, k);
        r.reading_um = cell(kProbeValueColumns[k]).number();
        readings.push_back(r);
      }
      continue;
    }
    Reading r;
    r.line = line_no;
    r.installation = cells[col.at("installation")];
    if (r.installation.empty()) cell("installation").fail("empty installation id");
    r.angle_deg = cell("angle_deg").number();
    if (col.count("reading_mm")) {
      r.reading_um = 1000.0 * cell("reading_mm").number();
      if (!std::isfinite(r.reading_um))
        cell("reading_mm")
            .fail(quote_value(cells[col.at("reading_mm")]) +
                  " mm is beyond the range of any instrument");
      r.in_mm = true;
    } else {
      r.reading_um = cell("reading_um").number();
    }
    if (present("time_s")) r.time_s = cell("time_s").number();
    if (present("sweep")) {
      const std::string& s = cells[col.at("sweep")];
      if (s == "cw") {
        r.sweep = Sweep::kCW;
      } else if (s == "ccw") {
        r.sweep = Sweep::kCCW;
      } else {
        cell("sweep").fail(quote_value(s) + " is not a sweep (expected cw or ccw)");
      }
    }
    if (present("repeat")) r.repeat = cell("repeat").integer();
    if (present("std_um")) {
      r.std_um = cell("std_um").number();
      if (!(*r.std_um >= 0) || *r.std_um > kMaxAbsReading_um)
        cell("std_um").fail(quote_value(cells[col.at("std_um")]) +
                            " is not a scatter (>= 0 and at most the largest range, in um)");
    }
    if (present("samples")) {
      r.samples = cell("samples").integer();
      if (*r.samples < 1) cell("samples").fail("the number of samples must be at least 1");
    }
    if (present("u_a_um")) {
      r.u_a_um = cell("u_a_um").number();
      if (!(*r.u_a_um >= 0) || *r.u_a_um > kMaxAbsReading_um)
        cell("u_a_um").fail(quote_value(cells[col.at("u_a_um")]) +
                            " is not a standard uncertainty (>= 0 and at most the largest "
                            "range, in um)");
    }
    if (present("u_a_dof")) {
      r.u_a_dof = cell("u_a_dof").integer();
      if (*r.u_a_dof < 1) cell("u_a_dof").fail("the degrees of freedom must be at least 1");
    }
    if (r.u_a_um.has_value() != r.u_a_dof.has_value()) {
      throw InputError(source, where,
                       "u_a_um and u_a_dof go together (a Type A uncertainty and its degrees of "
                       "freedom)");
    }
    if (readings.size() >= limits::kMaxReadings) {
      throw InputError(source, where,
                       "more than " + std::to_string(limits::kMaxReadings) +
                           " readings, the most one file may hold (docs/formats.md, \"Limits\")");
    }
    readings.push_back(r);
  }
  if (header.empty()) throw InputError(source, "", "the file is empty (no header line)");
  if (readings.empty()) throw InputError(source, "", "no readings after the header line");
  return readings;
}

}  // namespace

std::vector<Reading> parse_measurements(const std::string& text, const std::string& source) {
  bool probe = false;
  return parse(text, source, probe);
}

std::vector<Reading> read_measurement_file(const std::string& path, const Design& design) {
  bool probe_file = false;
  std::vector<Reading> readings = parse(read_text_file(path), path, probe_file);
  // The file's instrument is the design's.
  if (design.instrument == InstrumentKind::kProbe && !probe_file)
    throw InputError(path, "line 1",
                     "the design is a touch probe's: its file has the columns sphere, angle_deg, "
                     "dx_um, dy_um, dz_um[, repeat] (docs/formats.md)");
  if (design.instrument != InstrumentKind::kProbe && probe_file)
    throw InputError(path, "line 1",
                     "a touch probe's readings (a column sphere) for a ball bar's design");
  if (probe_file) {
    const auto index = design.installation_index();
    for (const Reading& r : readings)
      if (!index.count(r.installation))
        throw InputError(path, "line " + std::to_string(r.line),
                         "sphere " +
                             quote_value(r.installation.substr(0, r.installation.size() - 2)) +
                             " is not in the design");
  }
  validate_readings(design, readings, path);
  return readings;
}

void write_measurements_csv(std::ostream& out, const std::vector<Reading>& readings,
                            const Design& design) {
  if (design.instrument == InstrumentKind::kProbe) {
    write_probe_measurements_csv(out, design, readings);
  } else {
    write_measurements_csv(out, readings);
  }
}

void write_measurements_csv(std::ostream& out, const std::vector<Reading>& readings) {
  bool time = false, sweep = false, repeat = false, scatter = false, samples = false,
       type_a = false;
  for (const Reading& r : readings) {
    time = time || r.time_s.has_value();
    sweep = sweep || r.sweep.has_value();
    repeat = repeat || r.repeat.has_value();
    scatter = scatter || r.std_um.has_value();
    samples = samples || r.samples.has_value();
    type_a = type_a || r.u_a_um.has_value();
  }
  out << "installation,angle_deg,reading_um";
  if (time) out << ",time_s";
  if (sweep) out << ",sweep";
  if (repeat) out << ",repeat";
  if (scatter) out << ",std_um";
  if (samples) out << ",samples";
  if (type_a) out << ",u_a_um,u_a_dof";
  out << "\n";
  for (const Reading& r : readings) {
    out << r.installation << "," << std::setprecision(12) << r.angle_deg << "," << std::fixed
        << std::setprecision(6) << r.reading_um << std::defaultfloat;
    if (time) {
      out << ",";
      if (r.time_s) out << std::setprecision(12) << *r.time_s;
    }
    if (sweep) {
      out << ",";
      if (r.sweep) out << sweep_name(*r.sweep);
    }
    if (repeat) {
      out << ",";
      if (r.repeat) out << *r.repeat;
    }
    if (scatter) {
      out << ",";
      if (r.std_um) out << std::fixed << std::setprecision(6) << *r.std_um << std::defaultfloat;
    }
    if (samples) {
      out << ",";
      if (r.samples) out << *r.samples;
    }
    if (type_a) {
      out << ",";
      if (r.u_a_um) out << std::fixed << std::setprecision(6) << *r.u_a_um << std::defaultfloat;
      out << ",";
      if (r.u_a_dof) out << *r.u_a_dof;
    }
    out << "\n";
  }
}

}  // namespace dbbkit::io
