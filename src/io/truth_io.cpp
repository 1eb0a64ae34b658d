#include "dbbkit/io/truth_io.hpp"

#include <cmath>

#include "dbbkit/error.hpp"
#include "dbbkit/io/design_io.hpp"
#include "dbbkit/io/json_reader.hpp"
#include "dbbkit/user_text.hpp"
#include "design_reader.hpp"
#include "object_reader.hpp"
#include "result_blocks.hpp"

namespace dbbkit::io {

using nlohmann::json;

namespace {

// The "errors" object: per_angle values or series coefficients.
void read_errors(ObjectReader& top, const std::string& source, Truth& t) {
  ObjectReader errors = top.object("errors");
  const std::string model = errors.string("model");
  if (model == "per_angle") {
    t.model.kind = ErrorModel::Kind::kPerAngle;
    const json& values = errors.required("values");
    if (!values.is_array() || values.empty())
      errors.fail("values", "expected a non-empty list of {angle_deg, dx, ..., ez}");
    for (size_t i = 0; i < values.size(); ++i) {
      ObjectReader v(values[i], source, "errors.values[" + std::to_string(i) + "]");
      v.allow({"angle_deg", "dx", "dy", "dz", "ex", "ey", "ez"});
      Vector6d e;
      const double a = v.number("angle_deg");
      for (int k = 0; k < 6; ++k) e(k) = v.number(kErrorNames[k]);
      v.finish();
      t.per_angle.emplace_back(a, e);
    }
  } else if (model == "fourier" || model == "legendre") {
    t.model.kind = model == "fourier" ? ErrorModel::Kind::kFourier : ErrorModel::Kind::kLegendre;
    t.model.order = errors.integer("order");
    if (t.model.order < 0) errors.fail("order", "must be >= 0");
    if (t.model.kind == ErrorModel::Kind::kLegendre) {
      const json& r = errors.required("range_deg");
      if (!r.is_array() || r.size() != 2) errors.fail("range_deg", "expected [min, max]");
      t.range_deg = std::make_pair(as_number(r[0], source, "errors.range_deg[0]"),
                                   as_number(r[1], source, "errors.range_deg[1]"));
      if (!(t.range_deg->second > t.range_deg->first))
        errors.fail("range_deg", "max must exceed min");
    }
    ObjectReader coeffs = errors.object("coefficients");
    coeffs.allow({"dx", "dy", "dz", "ex", "ey", "ez"});
    for (int k = 0; k < 6; ++k) {
      const json& c = coeffs.required(kErrorNames[k]);
      const std::string path = coeffs.key_path(kErrorNames[k]);
      if (!c.is_array()) throw InputError(source, path, "expected a list of coefficients");
      for (size_t i = 0; i < c.size(); ++i) {
        t.coefficients[k].push_back(as_number(c[i], source, path + "[" + std::to_string(i) + "]"));
      }
    }
    coeffs.finish();
  } else {
    errors.fail("model", "unknown model " + quote_value(model) +
                             " (expected per_angle, fourier or legendre)");
  }
  errors.finish();
}

// An effect's value as its kind's truth form states it (EffectInfo::truth_value), its position's
// keys with it.
void read_truth_value(const json& v, const std::string& source, const std::string& vpath,
                      TruthEffect& te) {
  const EffectInfo& info = effect_info(te.effect.kind);
  const std::vector<std::string> names = effect_parameter_names(te.effect.kind);
  switch (info.truth_value) {
    case TruthValue::kNumber:
      te.value(0) = as_number(v, source, vpath);
      return;
    case TruthValue::kList: {
      std::string shorter, all;
      for (std::size_t k = 0; k < names.size(); ++k) {
        all += (k ? ", " : "") + names[k];
        if (k + 1 < names.size()) shorter = all;
      }
      if (!v.is_array() || v.size() + 1 < names.size() || v.size() > names.size())
        throw InputError(source, vpath,
                         "expected [" + shorter + "] or [" + all + "] in " + info.unit);
      for (std::size_t k = 0; k < v.size(); ++k)
        te.value(static_cast<Eigen::Index>(k)) =
            as_number(v[k], source, vpath + "[" + std::to_string(k) + "]");
      return;
    }
    case TruthValue::kNamed: {
      ObjectReader o(v, source, vpath);
      for (std::size_t k = 0; k < names.size(); ++k)
        te.value(static_cast<Eigen::Index>(k)) = o.optional_number(names[k]).value_or(0.0);
      o.finish();
      return;
    }
    case TruthValue::kObject:
      break;
  }
  ObjectReader o(v, source, vpath);
  switch (info.position) {  // the position's required key first, then the value
    case EffectPosition::kHarmonic:
      te.effect.harmonic = o.integer("harmonic");
      if (te.effect.harmonic < 1) o.fail("harmonic", "must be >= 1");
      break;
    case EffectPosition::kTime:
      te.effect.at_s = o.number("at_s");
      break;
    case EffectPosition::kTimeConstant:
      te.effect.tau_min = o.number("tau_min");
      if (!(te.effect.tau_min > 0) || !std::isfinite(te.effect.tau_min))
        o.fail("tau_min", "must be a finite time > 0 min");
      break;
    case EffectPosition::kNone:
      break;
  }
  te.value(0) = o.number(info.truth_value_key);
  if (info.position == EffectPosition::kHarmonic)
    te.effect.phase_deg = o.optional_number("phase_deg").value_or(0.0);
  o.finish();
}

}  // namespace

Truth truth_from_json(const json& j, const std::string& source) {
  ObjectReader top(j, source, "");
  Truth t;
  const std::string format = top.string("format");
  if (format != kTruthFormat)
    top.fail("format", "expected \"" + std::string(kTruthFormat) + "\", found \"" + format + "\"");
  top.optional_string("description");
  // A location of the axis (ISO 230-1 names of the design's axis, um and urad), resolved
  // against the design by validate_truth; with it the errors may be left out (zero).
  if (const json* loc = top.optional("location")) {
    if (!loc->is_object())
      top.fail("location",
               "expected an object of location errors, e.g. {\"X0C\": 10, \"B0C\": -20}");
    if (loc->empty())
      top.fail("location", "is empty: name at least one location error, e.g. {\"X0C\": 10}");
    for (auto it = loc->begin(); it != loc->end(); ++it) {
      if (const auto p = id_problem(it.key()))
        throw InputError(source, "location", quote_value(it.key()) + ": " + *p);
      t.location.emplace_back(it.key(), as_number(it.value(), source, "location." + it.key()));
    }
  }
  if (t.location.empty() || top.optional("errors")) {
    read_errors(top, source, t);
  } else {
    t.errors_given = false;
  }
  if (const json* n = top.optional("noise")) {
    t.noise = read_noise(ObjectReader(*n, source, "noise"), true);
    t.noiseless = !t.noise.has_value();
  }
  if (const json* list = top.optional("effects")) {
    if (!list->is_array()) top.fail("effects", "expected a list of effects");
    for (std::size_t i = 0; i < list->size(); ++i) {
      const std::string path = "effects[" + std::to_string(i) + "]";
      ObjectReader e((*list)[i], source, path);
      TruthEffect te;
      te.effect.kind = effect_kind(e.string("name"), source, path + ".name");
      te.installation = e.optional_string("installation").value_or("");
      te.value = Eigen::VectorXd::Zero(
          static_cast<Eigen::Index>(effect_parameter_names(te.effect.kind).size()));
      const json& v = e.required("value");
      const std::string vpath = path + ".value";
      read_truth_value(v, source, vpath, te);
      e.finish();
      t.effects.push_back(te);
    }
  }
  if (const json* sc = top.optional("schedule")) {
    ObjectReader o(*sc, source, "schedule");
    Schedule s;
    s.per_reading_s = o.optional_number("per_reading_s").value_or(s.per_reading_s);
    s.per_installation_s = o.optional_number("per_installation_s").value_or(s.per_installation_s);
    if (const json* sw = o.optional("sweeps")) {
      if (!sw->is_array() || sw->empty())
        o.fail("sweeps", "expected a list of \"ccw\" and/or \"cw\"");
      s.sweeps.clear();
      for (std::size_t k = 0; k < sw->size(); ++k) {
        const std::string x =
            as_string((*sw)[k], source, "schedule.sweeps[" + std::to_string(k) + "]");
        if (x != "cw" && x != "ccw")
          o.fail("sweeps", quote_value(x) + " is not a sweep (cw or ccw)");
        s.sweeps.push_back(x == "cw" ? Sweep::kCW : Sweep::kCCW);
      }
    }
    o.finish();
    t.schedule = s;
  }
  if (const auto g = top.optional_string("geometry")) {
    if (*g != "first_order" && *g != "exact")
      top.fail("geometry", quote_value(*g) + " is not a geometry (first_order or exact)");
    t.exact = *g == "exact";
  }
  t.bar_mm = top.optional_number("bar_mm");
  if (const json* su = top.optional("setup")) {
    ObjectReader s(*su, source, "setup");
    // A size in um or mm: finite, >= 0 for a standard uncertainty, within the documented limits.
    auto size = [&](ObjectReader& o, const std::string& key, double limit,
                    bool signed_value) -> double {
      const double x = o.number(key);
      if (!std::isfinite(x) || std::abs(x) > limit || (!signed_value && x < 0)) {
        o.fail(key, signed_value
                        ? "must be a finite number within +-" + std::to_string(limit)
                        : "must be a standard uncertainty in [0, " + std::to_string(limit) + "]");
      }
      return x;
    };
    auto ball = [&](ObjectReader& o, bool signed_value) {
      Eigen::Vector3d b = Eigen::Vector3d::Zero();
      if (const json* bm = o.optional("ball_mm")) {
        ObjectReader r(*bm, source, o.key_path("ball_mm"));
        const char* names[] = {"L", "D", "H"};
        for (int k = 0; k < 3; ++k) {
          if (r.has(names[k])) b(k) = size(r, names[k], 100.0, signed_value);
        }
        r.finish();
      }
      return b;
    };
    if (const json* d = s.optional("draw")) {
      ObjectReader r(*d, source, "setup.draw");
      if (r.has("length_offset_um"))
        t.setup_draw.length_offset_um = size(r, "length_offset_um", 1e4, false);
      if (r.has("centring_um")) t.setup_draw.centring_um = size(r, "centring_um", 1e4, false);
      t.setup_draw.ball_mm = ball(r, false);
      r.finish();
    }
    if (const json* given = s.optional("installations")) {
      if (!given->is_object())
        s.fail("installations", "expected {\"<id>\": {length_offset_um, centring_um, ball_mm}}");
      for (auto it = given->begin(); it != given->end(); ++it) {
        ObjectReader r(it.value(), source, "setup.installations." + it.key());
        SetupError e;
        if (r.has("length_offset_um")) e.length_offset_um = size(r, "length_offset_um", 1e4, true);
        if (const json* c = r.optional("centring_um")) {
          const std::string path = r.key_path("centring_um");
          if (!c->is_array() || c->size() < 2 || c->size() > 3) {
            throw InputError(source, path, "expected [cx, cy] or [cx, cy, cz] in um");
          }
          for (std::size_t k = 0; k < c->size(); ++k) {
            const double x = as_number((*c)[k], source, path + "[" + std::to_string(k) + "]");
            if (!std::isfinite(x) || std::abs(x) > 1e4) {
              throw InputError(source, path + "[" + std::to_string(k) + "]",
                               "must be within +-1e4 um");
            }
            e.centring_um(static_cast<Eigen::Index>(k)) = x;
          }
        }
        e.ball_mm = ball(r, true);
        r.finish();
        t.setup_given.emplace_back(it.key(), e);
      }
    }
    s.finish();
  }
  t.repeats = top.optional_integer("repeats").value_or(1);
  if (t.repeats < 1) top.fail("repeats", "must be an integer >= 1");
  if (const json* s = top.optional("seed")) {
    if (!s->is_number_unsigned()) top.fail("seed", "expected a non-negative integer");
    t.seed = s->get<std::uint64_t>();
  }
  top.finish();
  return t;
}

nlohmann::json setup_errors_to_json(const Design& design, const std::vector<SetupError>& setup) {
  // A zero drawn as -0 (a zero tolerance times a negative draw) is written 0.
  auto z = [](double x) { return x == 0.0 ? 0.0 : x; };
  json list = json::array();
  for (size_t i = 0; i < setup.size() && i < design.installations.size(); ++i) {
    const SetupError& e = setup[i];
    list.push_back(
        {{"id", design.installations[i].id},
         {"length_offset_um", z(e.length_offset_um)},
         {"centring_um", {z(e.centring_um(0)), z(e.centring_um(1)), z(e.centring_um(2))}},
         {"ball_mm", {{"L", z(e.ball_mm(0))}, {"D", z(e.ball_mm(1))}, {"H", z(e.ball_mm(2))}}}});
  }
  return {{"format", "dbbkit.setup-errors/1"}, {"installations", list}};
}

Truth read_truth_file(const std::string& path) {
  return truth_from_json(parse_json(read_json_file(path), path), path);
}

}  // namespace dbbkit::io
