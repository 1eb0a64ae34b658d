#include "dbbkit/io/chain_io.hpp"

#include <sstream>

#include "dbbkit/error.hpp"
#include "dbbkit/io/text.hpp"
#include "dbbkit/user_text.hpp"

namespace dbbkit::io {

using nlohmann::json;

ChainInput chain_input(const Machine& m, const ResultFile& r) {
  if (!r.machine)
    throw InputError(r.source, "design.machine",
                     "missing: the result's design names no machine (\"machine\": \"m.json\", "
                     "formats.md, \"Machine file\"); chain combines results measured on one");
  if (r.machine->name != m.name)
    throw InputError(
        r.source, "design.machine.name",
        "measured on machine " + quote_value(r.machine->name) + ", not " + quote_value(m.name));
  ChainInput in;
  in.source = r.source;
  in.letter = r.machine->axis;
  const int k = m.find(in.letter);
  if (k < 0)
    throw InputError(
        r.source, "design.machine.axis",
        std::string("axis ") + in.letter + " is not an axis of machine " + quote_value(m.name));
  in.park_deg = m.park_angles(r.machine->park_deg);
  in.park_deg[k] = 0;
  for (const auto& [letter, angle] : r.machine->park_deg)
    if (m.find(letter) < 0)
      throw InputError(r.source, "design.machine.park_deg." + std::string(1, letter),
                       "not an axis of machine " + quote_value(m.name));
  const AxisFrame frame = m.axis_frame(k, in.park_deg);
  if (const std::string diff = axis_difference(frame, r.axis); !diff.empty())
    throw InputError(r.source, "design.axis_definition",
                     "not axis " + std::string(1, in.letter) + " of this machine file: " + diff);
  in.origin_mm = r.machine->origin_mm;
  if (!r.location_covariance)
    throw InputError(r.source, "iso230.location_covariance",
                     "missing (a result of an earlier version): run identify or diagnose again");
  if (r.location.size() != 5)
    throw InputError(r.source, "iso230.location", "expected the five location errors");
  for (int e = 0; e < 5; ++e) {
    in.names[e] = r.location[e].name;
    in.value[e] = r.location[e].value;
  }
  in.covariance = *r.location_covariance;
  in.warnings = r.warnings;
  return in;
}

namespace {

json quantity_json(const ChainQuantity& q) {
  auto num = [](const std::optional<double>& v) { return v ? json(*v) : json(nullptr); };
  return {{"name", q.name},
          {"unit", q.unit},
          {"value", num(q.value)},
          {"std", num(q.std)},
          {"U", num(q.U)}};
}

std::string quantity_text(const ChainQuantity& q) {
  if (!q.value) return "not determined (a location error it needs is not)";
  return fmt_num(*q.value, 3) + " +- " + fmt_num(*q.U, 3) + " " + q.unit + " (U, std " +
         fmt_num(*q.std, 3) + ")";
}

std::string term_text(const ChainTerm& t) {
  const std::string pair = std::string(1, t.b) + " to " + std::string(1, t.a);
  if (t.name == "squareness")
    return "squareness " + pair + " (their angle minus " + fmt_rounded(t.nominal, 6) + " deg)";
  return "distance " + pair + " along " + direction_text(t.along) + " (minus the nominal " +
         fmt_rounded(t.nominal, 6) + " mm)";
}

}  // namespace

json chain_to_json(const ChainResult& r, const Machine& m, const std::string& machine_file) {
  json j;
  j["format"] = kChainFormat;
  j["dbbkit_version"] = DBBKIT_VERSION;
  j["machine"] = {
      {"name", m.name}, {"file", machine_file}, {"controller", controller_name(m.controller)}};
  j["coverage_probability"] = r.coverage_probability;
  j["k"] = r.k;
  j["uncertainty"] =
      "std: combined standard uncertainty (k = 1) of the axes' location errors (each result's "
      "iso230.location_covariance; independent tests, so the covariances add), propagated to "
      "first order; U = k std, k the normal quantile of the coverage probability";
  json axes = json::array();
  for (const ChainAxis& a : r.axes) {
    const RotaryAxisSpec& spec = m.rotary[static_cast<std::size_t>(m.find(a.letter))];
    json loc = json::array();
    for (const ChainQuantity& q : a.location) loc.push_back(quantity_json(q));
    axes.push_back({{"letter", std::string(1, a.letter)},
                    {"result", a.source},
                    {"side", spec.side == AxisFrame::Side::kTable ? "table" : "head"},
                    {"point_mm", {spec.point_mm.x(), spec.point_mm.y(), spec.point_mm.z()}},
                    {"direction", {spec.direction.x(), spec.direction.y(), spec.direction.z()}},
                    {"location", loc}});
  }
  j["axes"] = axes;
  // The results' warnings: each makes the uncertainties that use its axis unreliable.
  json warnings = json::array();
  for (const ChainAxis& a : r.axes)
    for (const std::string& w : a.warnings)
      warnings.push_back({{"axis", std::string(1, a.letter)},
                          {"result", a.source},
                          {"text", "the result of axis " + std::string(1, a.letter) +
                                       " warns (its U and every chain term's that uses it "
                                       "may be too small): " +
                                       w}});
  j["warnings"] = warnings;
  json chain = json::array();
  for (const ChainTerm& t : r.terms) {
    json e = quantity_json(t.q);
    e["between"] = {std::string(1, t.a), std::string(1, t.b)};
    e["text"] = term_text(t);
    if (t.name == "distance") {
      e["nominal_mm"] = t.nominal;
      e["along"] = {t.along.x(), t.along.y(), t.along.z()};
    } else {
      e["nominal_deg"] = t.nominal;
    }
    chain.push_back(e);
  }
  j["chain"] = chain;
  return j;
}

std::string chain_text(const ChainResult& r, const Machine& m) {
  std::ostringstream s;
  for (const ChainAxis& a : r.axes)
    for (const std::string& w : a.warnings)
      s << "WARNING: the result of axis " << a.letter << " (" << a.source
        << ") warns; its U and every chain term's that uses it may be too small: " << w << "\n";
  s << "machine " << m.name << " (controller " << controller_name(m.controller)
    << "): the axes on the controller's reference (each against the machine file's line, in "
       "its carrier's body), U at "
    << fmt_rounded(100 * r.coverage_probability, 3) << " % (k = " << fmt_num(r.k, 3) << ")\n";
  for (const ChainAxis& a : r.axes) {
    s << "  axis " << a.letter << " (" << a.source << "):\n";
    for (const ChainQuantity& q : a.location)
      s << "    " << q.name << " " << quantity_text(q) << "\n";
  }
  s << "  the chain (the real relation minus the nominal one):\n";
  for (const ChainTerm& t : r.terms)
    s << "    " << term_text(t) << ": " << quantity_text(t.q) << "\n";
  return s.str();
}

}  // namespace dbbkit::io
