#include "dbbkit/measurement.hpp"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <sstream>
#include <unordered_map>
#include <utility>

#include "dbbkit/error.hpp"
#include "dbbkit/parameterisation.hpp"
#include "dbbkit/user_text.hpp"

namespace dbbkit {

const char* sweep_name(Sweep s) { return s == Sweep::kCW ? "cw" : "ccw"; }

std::vector<Reading> nominal_readings(const Design& design) {
  std::vector<Reading> out;
  out.reserve(design.installations.size() * design.angles_deg.size());
  for (const Installation& in : design.installations) {
    for (double a : design.angles_deg) {
      Reading r;
      r.installation = in.id;
      r.angle_deg = a;
      out.push_back(std::move(r));
    }
  }
  return out;
}

void validate_readings(const Design& design, const std::vector<Reading>& readings,
                       const std::string& source) {
  if (readings.empty()) throw InputError(source, "", "no readings");
  const Parameterisation positions(design);
  const auto [lo, hi] = std::minmax_element(design.angles_deg.begin(), design.angles_deg.end());
  const std::unordered_map<std::string, int> index = design.installation_index();
  for (size_t i = 0; i < readings.size(); ++i) {
    const Reading& r = readings[i];
    const std::string where =
        r.line > 0 ? "line " + std::to_string(r.line) : "reading " + std::to_string(i);
    if (!index.count(r.installation)) {
      throw InputError(source, where,
                       "installation " + quote_value(r.installation) + " is not in the design");
    }
    if (!std::isfinite(r.angle_deg))
      throw InputError(source, where, "angle is not a finite number");
    if (positions.station_of(r.angle_deg) < 0) {
      std::ostringstream s;
      s << "angle " << std::setprecision(12) << r.angle_deg
        << " deg is not a position of the design";
      if (!design.axis.full_turn() && (r.angle_deg < *lo || r.angle_deg > *hi)) {
        s << " (outside its range " << *lo << " .. " << *hi << " deg)";
      }
      throw InputError(source, where, s.str());
    }
    if (!std::isfinite(r.reading_um))
      throw InputError(source, where, "reading is not a finite number");
    if (std::abs(r.reading_um) > 1000.0 * design.instrument_range_mm) {
      std::ostringstream s;
      if (r.in_mm) {
        s << std::setprecision(12) << "reading_mm " << r.reading_um / 1000.0
          << " is beyond the instrument's range of +-" << design.instrument_range_mm << " mm";
        // Twice the range or more: a unit mix-up, most likely (um written as mm).
        if (std::abs(r.reading_um) >= 2.0 * 1000.0 * design.instrument_range_mm)
          s << ": are the readings in um? (give them in a reading_um column)";
      } else {
        s << std::setprecision(12) << "reading " << r.reading_um
          << " um is beyond the instrument's range of +-" << design.instrument_range_mm << " mm";
      }
      s << "; the range is the design's instrument.range_mm (default " << kDefaultInstrumentRange_mm
        << " mm)";
      throw InputError(source, where, s.str());
    }
    if (r.time_s && (!std::isfinite(*r.time_s) || *r.time_s < 0)) {
      std::ostringstream m;
      m << "time_s must be a finite number of seconds >= 0, got " << std::setprecision(12)
        << *r.time_s;
      throw InputError(source, where, m.str());
    }
    if (r.repeat && *r.repeat < 0)
      throw InputError(source, where, "repeat must be an integer >= 0");
  }
  // A row pasted twice would count as a new repeat and shrink every uncertainty: two rows of
  // one installation, angle and sweep with the same repeat index, or with the same time,
  // are one reading given twice.
  struct Key {
    std::string installation;
    double angle;
    int sweep;
    int kind;  // 0: repeat index, 1: time
    double value;
    bool operator==(const Key& o) const {
      return installation == o.installation && angle == o.angle && sweep == o.sweep &&
             kind == o.kind && value == o.value;
    }
  };
  struct KeyHash {
    size_t operator()(const Key& k) const {
      return std::hash<std::string>()(k.installation) ^ (std::hash<double>()(k.angle) * 31) ^
             (std::hash<double>()(k.value) * 131) ^ static_cast<size_t>(k.sweep * 7 + k.kind);
    }
  };
  std::unordered_map<Key, size_t, KeyHash> seen;
  for (size_t i = 0; i < readings.size(); ++i) {
    const Reading& r = readings[i];
    const int sweep = r.sweep ? static_cast<int>(*r.sweep) : -1;
    for (int kind = 0; kind < 2; ++kind) {
      const std::optional<double> v =
          kind == 0 ? (r.repeat ? std::optional<double>(*r.repeat) : std::nullopt) : r.time_s;
      if (!v) continue;
      const auto [it, fresh] = seen.emplace(Key{r.installation, r.angle_deg, sweep, kind, *v}, i);
      if (fresh) continue;
      const Reading& first = readings[it->second];
      auto where = [&](const Reading& x, size_t k) {
        return x.line > 0 ? "line " + std::to_string(x.line) : "reading " + std::to_string(k);
      };
      std::ostringstream m;
      m << std::setprecision(12) << "the same reading as " << where(first, it->second)
        << " (installation " << r.installation << ", angle " << r.angle_deg << " deg"
        << (r.sweep ? std::string(", sweep ") + sweep_name(*r.sweep) : std::string())
        << (kind == 0 ? ", repeat " : ", time_s ") << *v
        << "): a row given twice? Repeats of a reading differ in their repeat index or time";
      throw InputError(source, where(r, i), m.str());
    }
  }
}

}  // namespace dbbkit
