#include "dbbkit/io/kit_io.hpp"

#include "dbbkit/error.hpp"
#include "dbbkit/io/design_io.hpp"
#include "dbbkit/io/json_reader.hpp"

namespace dbbkit::io {

using nlohmann::json;

namespace {

Interval read_min_max(ObjectReader r) {
  Interval i;
  i.min = r.number("min");
  i.max = r.number("max");
  r.finish();
  return i;
}

// [a, b]: a list of exactly two numbers.
Interval read_pair(const json& v, const std::string& source, const std::string& path) {
  if (!v.is_array() || v.size() != 2) throw InputError(source, path, "expected [min, max]");
  return {as_number(v[0], source, path + "[0]"), as_number(v[1], source, path + "[1]")};
}

std::vector<double> read_numbers(const json& v, const std::string& source, const std::string& path) {
  if (!v.is_array()) throw InputError(source, path, "expected a list of numbers");
  std::vector<double> out;
  for (size_t i = 0; i < v.size(); ++i) out.push_back(as_number(v[i], source, path + "[" + std::to_string(i) + "]"));
  return out;
}

}  // namespace

Kit kit_from_json(const json& j, const std::string& source) {
  ObjectReader top(j, source, "");
  Kit k;
  const std::string format = top.string("format");
  if (format != kKitFormat) top.fail("format", "expected \"" + std::string(kKitFormat) + "\", found \"" + format + "\"");
  k.name = top.optional_string("name").value_or("");
  top.optional_string("description");
  k.axis = read_axis(top);
  const std::string pattern = top.string("pattern");
  if (pattern == "three_position") {
    k.pattern = Kit::Pattern::ThreePosition;
  } else if (pattern == "free") {
    top.fail("pattern", "\"free\" is not supported by this version of dbbkit (supported: \"three_position\")");
  } else {
    top.fail("pattern", "unknown pattern '" + pattern + "' (expected \"three_position\")");
  }
  if (const json* n = top.optional("noise")) k.noise = *read_noise(ObjectReader(*n, source, "noise"), false);
  if (const json* e = top.optional("errors")) k.errors = read_error_model(ObjectReader(*e, source, "errors"));
  k.reference_length_mm = top.number("reference_length_mm");
  if (const json* u = top.optional("setup_std")) {
    k.setup_std = read_setup_override(ObjectReader(*u, source, "setup_std")).over({});
    validate_setup_uncertainty(k.setup_std, k.axis, source, "setup_std");
  }
  k.L_mm = read_min_max(top.object("L_mm"));
  if (top.has("D_mm")) k.D_mm = read_min_max(top.object("D_mm"));
  if (k.axis == Axis::C) {
    ObjectReader h = top.object("H_mm");
    k.H_base_mm = h.number("base");
    k.blocks_mm = read_numbers(h.required("blocks"), source, h.key_path("blocks"));
    k.max_stack = h.integer("max_stack");
    h.finish();
  } else if (top.has("H_mm")) {
    top.fail("H_mm", "H is not used for the swinging head B (ball at (L sin b, D, L cos b))");
  }
  k.bars_mm = read_numbers(top.required("bars_mm"), source, top.key_path("bars_mm"));
  {
    ObjectReader t = top.object("travel_mm");
    const char* names[] = {"x", "y", "z"};
    for (int i = 0; i < 3; ++i) k.travel_mm[i] = read_pair(t.required(names[i]), source, t.key_path(names[i]));
    t.finish();
  }
  k.min_separation_mm = top.optional_number("min_separation_mm").value_or(0.0);
  {
    ObjectReader a = top.object("angles_deg");
    k.angle_range_deg = read_pair(a.required("range"), source, a.key_path("range"));
    k.angle_steps_deg = read_numbers(a.required("steps"), source, a.key_path("steps"));
    a.finish();
  }
  {
    ObjectReader t = top.object("time_s");
    k.time_per_reading_s = t.number("per_reading");
    k.time_per_installation_s = t.number("per_installation");
    k.time_budget_s = t.optional_number("budget");
    t.finish();
  }
  top.finish();
  validate_kit(k, source);
  return k;
}

Kit kit_from_text(const std::string& text, const std::string& source) {
  return kit_from_json(parse_json(text, source), source);
}

Kit read_kit_file(const std::string& path) { return kit_from_text(read_text_file(path), path); }

}  // namespace dbbkit::io
