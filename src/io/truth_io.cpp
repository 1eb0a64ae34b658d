#include "dbbkit/io/truth_io.hpp"

#include "dbbkit/error.hpp"
#include "dbbkit/io/design_io.hpp"
#include "dbbkit/io/json_reader.hpp"

namespace dbbkit::io {

using nlohmann::json;

Truth truth_from_json(const json& j, const std::string& source) {
  ObjectReader top(j, source, "");
  Truth t;
  const std::string format = top.string("format");
  if (format != kTruthFormat) top.fail("format", "expected \"" + std::string(kTruthFormat) + "\", found \"" + format + "\"");
  top.optional_string("description");
  ObjectReader errors = top.object("errors");
  const std::string model = errors.string("model");
  if (model == "per_angle") {
    t.model.kind = ErrorModel::Kind::PerAngle;
    const json& values = errors.required("values");
    if (!values.is_array() || values.empty()) errors.fail("values", "expected a non-empty list of {angle_deg, dx, ..., ez}");
    for (size_t i = 0; i < values.size(); ++i) {
      ObjectReader v(values[i], source, "errors.values[" + std::to_string(i) + "]");
      Vector6d e;
      const double a = v.number("angle_deg");
      for (int k = 0; k < 6; ++k) e(k) = v.number(kErrorNames[k]);
      v.finish();
      t.per_angle.emplace_back(a, e);
    }
  } else if (model == "fourier" || model == "legendre") {
    t.model.kind = model == "fourier" ? ErrorModel::Kind::Fourier : ErrorModel::Kind::Legendre;
    t.model.order = errors.integer("order");
    if (t.model.order < 0) errors.fail("order", "must be >= 0");
    if (t.model.kind == ErrorModel::Kind::Legendre) {
      const json& r = errors.required("range_deg");
      if (!r.is_array() || r.size() != 2) errors.fail("range_deg", "expected [min, max]");
      t.range_deg = std::make_pair(as_number(r[0], source, "errors.range_deg[0]"),
                                   as_number(r[1], source, "errors.range_deg[1]"));
      if (!(t.range_deg->second > t.range_deg->first)) errors.fail("range_deg", "max must exceed min");
    }
    ObjectReader coeffs = errors.object("coefficients");
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
    errors.fail("model", "unknown model '" + model + "' (expected per_angle, fourier or legendre)");
  }
  errors.finish();
  if (const json* n = top.optional("noise")) {
    t.noise = read_noise(ObjectReader(*n, source, "noise"), true);
    t.noiseless = !t.noise.has_value();
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

Truth read_truth_file(const std::string& path) { return truth_from_json(parse_json(read_text_file(path), path), path); }

}  // namespace dbbkit::io
