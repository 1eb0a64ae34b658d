#include "dbbkit/measurement.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <unordered_map>

#include "dbbkit/error.hpp"
#include "dbbkit/parameterisation.hpp"

namespace dbbkit {

void validate_readings(const Design& design, const std::vector<Reading>& readings,
                       const std::string& source) {
  if (readings.empty()) throw InputError(source, "", "no readings");
  const Parameterisation positions(design);
  const auto [lo, hi] = std::minmax_element(design.angles_deg.begin(), design.angles_deg.end());
  const std::unordered_map<std::string, int> index = design.installation_index();
  for (size_t i = 0; i < readings.size(); ++i) {
    const Reading& r = readings[i];
    const std::string where = r.line > 0 ? "line " + std::to_string(r.line) : "reading " + std::to_string(i);
    if (!index.count(r.installation)) {
      throw InputError(source, where, "installation '" + r.installation + "' is not in the design");
    }
    if (!std::isfinite(r.angle_deg)) throw InputError(source, where, "angle is not a finite number");
    if (positions.station_of(r.angle_deg) < 0) {
      std::ostringstream s;
      s << "angle " << r.angle_deg << " deg is not a position of the design";
      if (design.axis == Axis::B && (r.angle_deg < *lo || r.angle_deg > *hi)) {
        s << " (outside its range " << *lo << " .. " << *hi << " deg)";
      }
      throw InputError(source, where, s.str());
    }
    if (!std::isfinite(r.reading_um)) throw InputError(source, where, "reading is not a finite number");
    if (std::abs(r.reading_um) > kMaxAbsReading_um) {
      std::ostringstream s;
      s << "reading " << r.reading_um << " um exceeds " << kMaxAbsReading_um
        << " um in magnitude, more than any DBB measures: is the column's unit right?";
      throw InputError(source, where, s.str());
    }
    if (r.time_s && (!std::isfinite(*r.time_s) || *r.time_s < 0)) {
      throw InputError(source, where, "time_s must be a finite number of seconds >= 0");
    }
    if (r.repeat && *r.repeat < 0) throw InputError(source, where, "repeat must be an integer >= 0");
  }
}

}  // namespace dbbkit
