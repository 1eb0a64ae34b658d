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
  out.reserve(static_cast<std::size_t>(design.readings_per_round()));
  for (int i = 0; i < static_cast<int>(design.installations.size()); ++i) {
    const Installation& in = design.installations[static_cast<std::size_t>(i)];
    const std::vector<double>& angles = design.angles_of(i);
    for (double a : angles) {
      Reading r;
      r.installation = in.id;
      r.angle_deg = a;
      out.push_back(std::move(r));
    }
    if (design.readings_per_sweep(i) > static_cast<int>(angles.size())) {
      Reading r;  // the return reading (design_model's row)
      r.installation = in.id;
      r.angle_deg = *std::min_element(angles.begin(), angles.end());
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
  // Each installation's own angles, sorted (empty: every angle of the design).
  std::vector<std::vector<double>> own_sorted;
  for (const Installation& in : design.installations) {
    own_sorted.push_back(in.angles_deg);
    std::sort(own_sorted.back().begin(), own_sorted.back().end());
  }
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
    if (const int k = index.at(r.installation); !own_sorted[k].empty()) {
      const std::vector<double>& own = own_sorted[k];
      if (angle_index(own, r.angle_deg) < 0) {
        std::ostringstream s;
        s << std::setprecision(12) << "angle " << r.angle_deg
          << " deg is not an angle of installation " << r.installation
          << " (its angles_deg: " << own.size() << " angles from " << own.front() << " to "
          << own.back() << " deg)";
        throw InputError(source, where, s.str());
      }
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
      // What the two have in common, and what else of them differs (the other of repeat and
      // time_s, the reading).
      std::ostringstream same;
      same << std::setprecision(12) << "installation " << r.installation << ", angle "
           << r.angle_deg << " deg"
           << (r.sweep ? std::string(", sweep ") + sweep_name(*r.sweep) : std::string())
           << (kind == 0 ? ", repeat " : ", time_s ") << *v;
      std::vector<std::string> differ;
      auto differs = [&](const char* name, std::optional<double> here, std::optional<double> there,
                         double scale) {
        if (here == there) return;
        std::ostringstream d;
        auto text = [scale](std::optional<double> x) {
          std::ostringstream t;
          t << std::setprecision(12);
          if (x)
            t << *x / scale;
          else
            t << "none";
          return t.str();
        };
        d << name << " (" << text(here) << " here, " << text(there) << " there)";
        differ.push_back(d.str());
      };
      auto repeat = [](const Reading& x) {
        return x.repeat ? std::optional<double>(*x.repeat) : std::nullopt;
      };
      if (kind == 0) differs("time_s", r.time_s, first.time_s, 1.0);
      if (kind == 1) differs("repeat", repeat(r), repeat(first), 1.0);
      differs(r.in_mm ? "reading_mm" : "reading_um", r.reading_um, first.reading_um,
              r.in_mm ? 1000.0 : 1.0);
      std::ostringstream m;
      if (differ.empty()) {
        m << "the same reading as " << where(first, it->second) << " (" << same.str()
          << "): a row given twice? Repeats of a reading differ in their "
          << (kind == 0 ? "repeat index" : "time_s");
      } else {
        std::string list;
        for (std::size_t k = 0; k < differ.size(); ++k)
          list += (k == 0 ? "" : k + 1 == differ.size() ? " and " : ", ") + differ[k];
        m << "the same " << (kind == 0 ? "repeat" : "time_s") << " as " << where(first, it->second)
          << " (" << same.str() << "), another " << list << ": "
          << (kind == 0 ? "two readings of one position with one repeat index; give each its "
                          "own repeat (or leave the repeat column out: time_s tells them apart)"
                        : "two readings of one position at one time; is a time_s mistyped, or "
                          "a row given twice and edited?");
      }
      throw InputError(source, where(r, i), m.str());
    }
  }
}

}  // namespace dbbkit
