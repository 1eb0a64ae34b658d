// A touch probe's measurement file (formats.md, "A second instrument"): one row per sphere, angle
// and repeat, sphere,angle_deg,dx_um,dy_um,dz_um[,repeat], the probed centre minus the nominal
// one in machine coordinates [um]; each row three readings, one a channel (instrument.hpp). Read
// by parse_measurements (measurement_io.cpp); written here.

#include <iomanip>
#include <map>
#include <optional>
#include <stdexcept>
#include <tuple>

#include "dbbkit/instrument.hpp"
#include "dbbkit/io/measurement_io.hpp"

namespace dbbkit::io {

bool probe_measurement_header(const std::vector<std::string>& header) {
  for (const std::string& h : header)
    if (h == "sphere") return true;
  return false;
}

void write_probe_measurements_csv(std::ostream& out, const Design& design,
                                  const std::vector<Reading>& readings) {
  const auto index = design.installation_index();
  bool repeat = false;
  for (const Reading& r : readings) repeat = repeat || r.repeat.has_value();
  // One row per sphere, angle and repeat, in the order the rows first appear.
  using Key = std::tuple<int, double, int>;
  std::map<Key, std::size_t> row_of;
  struct Row {
    int sphere = 0;
    double angle_deg = 0;
    std::optional<int> repeat;
    std::optional<double> value[3];
  };
  std::vector<Row> rows;
  for (const Reading& r : readings) {
    const Installation& c =
        design.installations.at(static_cast<std::size_t>(index.at(r.installation)));
    const Key key{c.sphere, r.angle_deg, r.repeat.value_or(-1)};
    auto [it, added] = row_of.emplace(key, rows.size());
    if (added) rows.push_back({c.sphere, r.angle_deg, r.repeat, {}});
    rows[it->second].value[c.coordinate] = r.reading_um;
  }
  out << "sphere,angle_deg,dx_um,dy_um,dz_um" << (repeat ? ",repeat" : "") << "\n";
  for (const Row& row : rows) {
    out << design.spheres.at(static_cast<std::size_t>(row.sphere)).id << ","
        << std::setprecision(12) << row.angle_deg;
    for (const auto& v : row.value) {
      if (!v) throw std::logic_error("a probe's row without all three coordinates");
      out << "," << std::fixed << std::setprecision(6) << *v << std::defaultfloat;
    }
    if (repeat) {
      out << ",";
      if (row.repeat) out << *row.repeat;
    }
    out << "\n";
  }
}

}  // namespace dbbkit::io
