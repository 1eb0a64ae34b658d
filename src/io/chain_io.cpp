#include "dbbkit/io/chain_io.hpp"

#include <Eigen/Eigenvalues>
#include <cmath>
#include <sstream>

#include "../number_text.hpp"
#include "dbbkit/error.hpp"
#include "dbbkit/io/json_reader.hpp"
#include "dbbkit/io/text.hpp"
#include "dbbkit/iso230.hpp"
#include "dbbkit/limits.hpp"
#include "dbbkit/user_text.hpp"
#include "object_reader.hpp"

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
  // The line and its frame, not the travel: a travel changed since does not move the axis.
  if (const std::string diff = axis_difference(frame, r.axis, false); !diff.empty())
    throw InputError(r.source, "design.axis_definition",
                     "not axis " + std::string(1, in.letter) + " of this machine file: " + diff);
  in.origin_mm = r.machine->origin_mm;
  if (r.location.size() != 5)
    throw InputError(r.source, "iso230.location",
                     std::to_string(r.location.size()) +
                         " entries: expected the five location "
                         "errors");
  if (!r.location_covariance)
    throw InputError(r.source, "iso230.location_covariance",
                     "missing (a result of an earlier version): run identify or diagnose again");
  const IsoNames iso = iso230_names(frame);
  for (int e = 0; e < 5; ++e) {
    if (r.location[e].name != iso.location[e])
      throw InputError(r.source, "iso230.location[" + std::to_string(e) + "].name",
                       quote_value(r.location[e].name) + ": expected " + iso.location[e] +
                           " here (the five location errors in ISO 230-1's order)");
    in.names[e] = r.location[e].name;
    in.value[e] = r.location[e].value;
  }
  in.covariance = *r.location_covariance;
  in.warnings = r.warnings;
  return in;
}

namespace {

json vec(const Eigen::Vector3d& v) { return {v.x(), v.y(), v.z()}; }

json quantity_json(const ChainQuantity& q) {
  auto num = [](const std::optional<double>& v) { return v ? json(*v) : json(nullptr); };
  return {{"name", q.name},
          {"unit", q.unit},
          {"value", num(q.value)},
          {"std", num(q.std)},
          {"U", num(q.U)}};
}

std::string quantity_text(const ChainQuantity& q, bool term = false) {
  if (!q.value)
    return term ? "not determined (a location error it needs is not)"
                : "not determined by the measurement";
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

namespace {

Eigen::Vector3d vector3(const json& v, const std::string& source, const std::string& path) {
  const std::vector<double> x = read_numbers(v, source, path);
  if (x.size() != 3) throw InputError(source, path, "expected three numbers");
  for (double c : x)
    if (!(std::abs(c) <= limits::kMaxLength_mm))
      throw InputError(source, path, "beyond +-10000 mm: not a machine's");
  return {x[0], x[1], x[2]};
}

std::optional<double> value_or_null(ObjectReader& o, const std::string& key, bool uncertainty) {
  const json& v = o.required(key);
  if (v.is_null()) return std::nullopt;
  const double x = as_number(v, o.source(), o.key_path(key));
  if (!(std::abs(x) <= 1e9)) o.fail(key, "beyond +-1e9 (um or urad): not a result of dbbkit");
  if (uncertainty && x < 0) o.fail(key, "is negative");
  return x;
}

std::string text_key(ObjectReader& o, const std::string& key) {
  const std::string t = o.string(key);
  if (const auto p = text_problem(t, 4000)) o.fail(key, quote_value(t) + ": " + *p);
  return t;
}

ResultQuantity chain_quantity(ObjectReader& o, double k) {
  ResultQuantity q;
  q.name = text_key(o, "name");
  q.unit = o.string("unit");
  if (q.unit != "um" && q.unit != "urad") o.fail("unit", "expected um or urad");
  q.value = value_or_null(o, "value", false);
  q.std = value_or_null(o, "std", true);
  if (q.value && !q.std) o.fail("std", "null: a value without its std");
  if (!q.value && q.std) o.fail("value", "null: a std without its value");
  if (q.std && !(*q.std > 0)) o.fail("std", "0: no measurement determines a value exactly");
  const json& U = o.required("U");
  if (!U.is_null() || q.value) {
    const double u = as_number(U, o.source(), o.key_path("U"));
    if (!q.std || std::abs(u - k * *q.std) > 1e-6 * (1 + u))
      o.fail("U", "is not k std (k = " + fmt_num(k, 6) + ")");
  }
  return q;
}

char letter_of(ObjectReader& o, const std::string& key) {
  const std::string l = o.string(key);
  if (l.size() != 1 || (l[0] != 'A' && l[0] != 'B' && l[0] != 'C'))
    o.fail(key, quote_value(l) + ": expected A, B or C");
  return l[0];
}

}  // namespace

bool is_chain_text(const std::string& text) {
  try {
    const json j = parse_json(text, "");  // depth and size bounded
    return j.is_object() && j.contains("format") && j["format"] == kChainFormat;
  } catch (const std::exception&) {
    return false;
  }
}

ChainFile chain_from_text(const std::string& text, const std::string& source) {
  const json j = parse_json(text, source);
  if (!j.is_object()) throw InputError(source, "", "expected a JSON object (dbbkit chain --out)");
  ObjectReader o(j, source, "");
  if (o.string("format") != kChainFormat)
    o.fail("format", "expected " + std::string(kChainFormat) + " (dbbkit chain --out)");
  ChainFile f;
  f.source = source;
  (void)text_key(o, "dbbkit_version");
  (void)text_key(o, "uncertainty");
  const double p = o.number("coverage_probability");
  if (!(p >= limits::kMinCoverage && p <= limits::kMaxCoverage))
    o.fail("coverage_probability", "expected " + text::significant(limits::kMinCoverage, 6) +
                                       " to " + text::significant(limits::kMaxCoverage, 6));
  const double k = o.number("k");
  if (!(k >= 0.5 && k <= 10)) o.fail("k", "expected a coverage factor, 0.5 to 10");
  {
    ObjectReader m = o.object("machine");
    f.machine_name = text_key(m, "name");
    (void)text_key(m, "file");
    if (m.has("sha256")) (void)text_key(m, "sha256");
    f.controller = m.string("controller");
    static const char* kControllers[] = {"heidenhain", "siemens", "fanuc",
                                         "linuxcnc",   "isg",     "generic"};
    bool known = false;
    for (const char* c : kControllers) known = known || f.controller == c;
    if (!known)
      m.fail("controller", quote_value(f.controller) +
                               " (expected heidenhain, siemens, fanuc, linuxcnc, isg or generic)");
    m.finish();
  }
  const json& axes = o.required("axes");
  if (!axes.is_array() || axes.size() < 2 || axes.size() > 6)
    o.fail("axes", "expected a list of two to six axes");
  for (std::size_t i = 0; i < axes.size(); ++i) {
    ObjectReader a(axes[i], source, "axes[" + std::to_string(i) + "]");
    ChainFileAxis x;
    x.letter = letter_of(a, "letter");
    for (const ChainFileAxis& other : f.axes)
      if (other.letter == x.letter) a.fail("letter", std::string("axis ") + x.letter + " twice");
    x.result = text_key(a, "result");
    if (a.has("result_sha256")) (void)text_key(a, "result_sha256");
    const std::string side = a.string("side");
    if (side != "table" && side != "head") a.fail("side", "expected table or head");
    x.table = side == "table";
    if (const json* on = a.optional("on"); on && !on->is_null()) x.on = letter_of(a, "on");
    x.point_mm = vector3(a.required("point_mm"), source, a.key_path("point_mm"));
    x.direction = vector3(a.required("direction"), source, a.key_path("direction"));
    if (std::abs(x.direction.norm() - 1) > 1e-9) a.fail("direction", "not a unit vector");
    // The axis along the machine axis its letter names (ISO 841; a controller's vector within
    // kNearAxis_rad of it): its five errors then have fixed ISO names, units and directions.
    const int ia = x.letter - 'A';
    const Eigen::Vector3d q_axis = Eigen::Vector3d::Unit(ia);
    if (x.direction.cross(q_axis).norm() > kNearAxis_rad || x.direction.dot(q_axis) <= 0)
      a.fail("direction", direction_text(x.direction) + " is not axis " + std::string(1, x.letter) +
                              "'s machine axis (+" + std::string(1, "XYZ"[ia]) +
                              "): compensation takes axes along the machine axes");
    // Its names and directions as identify gives them (iso230.hpp), not written again here.
    const AxisFrame frame =
        AxisFrame::general(x.letter, x.table ? AxisFrame::Side::kTable : AxisFrame::Side::kHead,
                           q_axis, Eigen::Vector3d::Unit((ia + 1) % 3), true);
    const IsoFrame iso = iso_frame(frame);
    const std::array<std::string, 5> names = iso230_names(frame).location;
    const std::array<Eigen::Vector3d, 5> vectors = {iso.p1, iso.p2, iso.p1, iso.p2, iso.q};
    const json& loc = a.required("location");
    if (!loc.is_array() || loc.size() != 5)
      a.fail("location", "expected the axis' five location errors");
    for (std::size_t e = 0; e < 5; ++e) {
      ObjectReader q(loc[e], source, a.key_path("location") + "[" + std::to_string(e) + "]");
      x.location.push_back(chain_quantity(q, k));
      const ResultQuantity& r = x.location.back();
      if (r.name != names[e])
        q.fail("name", quote_value(r.name) + ": expected " + names[e] + " here");
      if (r.unit != (e < 2 ? "um" : "urad"))
        q.fail("unit", std::string("expected ") + (e < 2 ? "um" : "urad"));
      // Beyond these a first-order model of the axis line does not hold.
      if (r.value && std::abs(*r.value) > (e < 2 ? 1e5 : 1e4))
        q.fail("value", fmt_num(*r.value, 6) + " " + r.unit + ": beyond " +
                            (e < 2 ? "+-100 mm" : "+-10 mrad") + ", no location error of an axis");
      x.vector[e] = vector3(q.required("vector"), source, q.key_path("vector"));
      if ((x.vector[e] - vectors[e]).norm() > 1e-12)
        q.fail("vector", "expected " + direction_text(vectors[e]) + " for " + names[e]);
      if (const json* m = q.optional("as_measured"); m && !m->is_null())
        (void)as_number(*m, source, q.key_path("as_measured"));
      q.finish();
    }
    a.finish();
    f.axes.push_back(x);
  }
  for (const ChainFileAxis& x : f.axes) {
    if (!x.on) continue;
    const ChainFileAxis* carrier = nullptr;
    for (const ChainFileAxis& c : f.axes)
      if (c.letter == x.on) carrier = &c;
    if (!carrier || carrier == &x)
      o.fail("axes", std::string("axis ") + x.letter + " is carried by " + x.on +
                         (carrier ? ", itself" : ", which the machine result does not hold"));
    if (carrier->table != x.table)
      o.fail("axes", std::string("axis ") + x.letter + " is carried by " + x.on +
                         " on the other side (table and head)");
    // No cycle: walking the carriers ends at the frame.
    char at = x.on;
    for (std::size_t step = 0; at; ++step) {
      if (step > f.axes.size())
        o.fail("axes", std::string("axis ") + x.letter + "'s carriers run in a circle");
      char next = 0;
      for (const ChainFileAxis& c : f.axes)
        if (c.letter == at) next = c.on;
      at = next;
    }
  }
  {
    ObjectReader c = o.object("location_covariance");
    (void)c.optional("order");
    const json& rows = c.required("matrix");
    const std::size_t n = 5 * f.axes.size();
    if (!rows.is_array() || rows.size() != n)
      c.fail("matrix", "expected " + std::to_string(n) + " rows (5 per axis)");
    f.covariance.resize(static_cast<Eigen::Index>(n), static_cast<Eigen::Index>(n));
    for (std::size_t i = 0; i < n; ++i) {
      const std::string path = c.key_path("matrix") + "[" + std::to_string(i) + "]";
      const std::vector<double> row = read_numbers(rows[i], source, path);
      if (row.size() != n)
        throw InputError(source, path, "expected " + std::to_string(n) + " numbers");
      for (std::size_t k = 0; k < n; ++k) {
        if (!(std::abs(row[k]) <= 1e18)) throw InputError(source, path, "a value beyond +-1e18");
        f.covariance(static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(k)) = row[k];
      }
    }
    const Eigen::Index N = static_cast<Eigen::Index>(n);
    const double scale = f.covariance.cwiseAbs().maxCoeff();
    for (Eigen::Index i = 0; i < N; ++i)
      for (Eigen::Index c = 0; c < i; ++c)
        if (std::abs(f.covariance(i, c) - f.covariance(c, i)) > 1e-9 * (1 + scale))
          throw InputError(
              source, "location_covariance.matrix",
              "not symmetric (row " + std::to_string(i) + ", column " + std::to_string(c) + ")");
    {
      const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(f.covariance);
      if (eig.info() != Eigen::Success || eig.eigenvalues().minCoeff() < -1e-9 * (1 + scale))
        throw InputError(source, "location_covariance.matrix",
                         "not a covariance (an eigenvalue is negative: was the file edited?)");
    }
    for (std::size_t i = 0; i < n; ++i) {
      const ResultQuantity& q = f.axes[i / 5].location[i % 5];
      const double var = f.covariance(static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(i));
      if (q.std && std::abs(std::sqrt(std::max(0.0, var)) - *q.std) > 1e-6 * (1 + *q.std))
        c.fail("matrix",
               "its diagonal is not the std squared of " + q.name + " (was the file edited?)");
    }
    c.finish();
  }
  const json& chain = o.required("chain");
  if (!chain.is_array()) o.fail("chain", "expected a list");
  for (std::size_t i = 0; i < chain.size(); ++i) {
    ObjectReader t(chain[i], source, "chain[" + std::to_string(i) + "]");
    ChainFileTerm term;
    term.q = chain_quantity(t, k);
    term.name = term.q.name;
    term.text = text_key(t, "text");
    const json& between = t.required("between");
    if (!between.is_array() || between.size() != 2 || !between[0].is_string() ||
        !between[1].is_string())
      t.fail("between", "expected two letters");
    for (int i = 0; i < 2; ++i) {
      const std::string l = between[static_cast<std::size_t>(i)].get<std::string>();
      bool known = false;
      for (const ChainFileAxis& x : f.axes) known = known || (l.size() == 1 && l[0] == x.letter);
      if (!known) t.fail("between", quote_value(l) + " is not an axis of the machine result");
    }
    term.a = between[0].get<std::string>()[0];
    term.b = between[1].get<std::string>()[0];
    if (term.name != "distance" && term.name != "squareness")
      t.fail("name", quote_value(term.name) + " (expected distance or squareness)");
    for (const char* key : {"nominal_mm", "nominal_deg"})
      if (t.has(key)) (void)t.number(key);
    if (t.has("along")) (void)vector3(t.required("along"), source, t.key_path("along"));
    t.finish();
    f.terms.push_back(term);
  }
  const json& warnings = o.required("warnings");
  if (!warnings.is_array()) o.fail("warnings", "expected a list");
  for (std::size_t i = 0; i < warnings.size(); ++i) {
    ObjectReader w(warnings[i], source, "warnings[" + std::to_string(i) + "]");
    (void)text_key(w, "axis");
    (void)text_key(w, "result");
    f.warnings.push_back(text_key(w, "text"));
    w.finish();
  }
  o.finish();
  return f;
}

ChainFile read_chain_file(const std::string& path) {
  return chain_from_text(read_json_file(path), path);
}

json chain_to_json(const ChainResult& r, const Machine& m, const std::string& machine_file,
                   const std::string& machine_sha256) {
  json j;
  j["format"] = kChainFormat;
  j["dbbkit_version"] = DBBKIT_VERSION;
  j["machine"] = {
      {"name", m.name}, {"file", machine_file}, {"controller", controller_name(m.controller)}};
  if (!machine_sha256.empty()) j["machine"]["sha256"] = machine_sha256;
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
    for (std::size_t e = 0; e < a.location.size(); ++e) {
      json q = quantity_json(a.location[e]);
      q["vector"] = vec(a.vector[e]);
      // A carried axis: its result's value, before the carriers' zero errors were turned back.
      if (spec.on >= 0) q["as_measured"] = a.measured[e] ? json(*a.measured[e]) : json(nullptr);
      loc.push_back(q);
    }
    json axis = {
        {"letter", std::string(1, a.letter)},
        {"result", a.source},
        {"side", spec.side == AxisFrame::Side::kTable ? "table" : "head"},
        {"on", spec.on < 0 ? json(nullptr) : json(std::string(1, m.rotary[spec.on].letter))},
        {"point_mm", vec(spec.point_mm)},
        {"direction", vec(spec.controllers_direction())},
        {"location", loc}};
    if (!a.sha256.empty()) axis["result_sha256"] = a.sha256;
    axes.push_back(axis);
  }
  j["axes"] = axes;
  {
    json rows = json::array();
    for (Eigen::Index i = 0; i < r.location_covariance.rows(); ++i) {
      json row = json::array();
      for (Eigen::Index c = 0; c < r.location_covariance.cols(); ++c)
        row.push_back(r.location_covariance(i, c));
      rows.push_back(row);
    }
    j["location_covariance"] = {
        {"order", "every axis' five location errors as axes lists them (um, urad)"},
        {"matrix", rows}};
  }
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
    const int k = m.find(a.letter);
    std::string carriers;
    for (const int c : m.carriers(k))
      carriers += (carriers.empty() ? "" : " and ") + std::string(1, m.rotary[c].letter);
    s << "  axis " << a.letter << " (" << a.source << ")"
      << (carriers.empty() ? ""
                           : ", in the body of " + carriers + " (measured with " + carriers +
                                 " at 0; its zero error turned back)")
      << ":\n";
    for (std::size_t e = 0; e < a.location.size(); ++e) {
      const ChainQuantity& q = a.location[e];
      s << "    " << q.name << " " << quantity_text(q);
      if (!carriers.empty() && q.value && a.measured[e] &&
          std::abs(*a.measured[e] - *q.value) >= 5e-4)
        s << ", as measured " << fmt_num(*a.measured[e], 3);
      s << "\n";
    }
  }
  s << "  the chain (the real relation minus the nominal one):\n";
  for (const ChainTerm& t : r.terms)
    s << "    " << term_text(t) << ": " << quantity_text(t.q, true) << "\n";
  return s.str();
}

}  // namespace dbbkit::io
