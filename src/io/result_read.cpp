#include "dbbkit/io/result_read.hpp"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <set>
#include <tuple>

#include "dbbkit/error.hpp"
#include "dbbkit/io/design_io.hpp"
#include "dbbkit/io/json_reader.hpp"
#include "dbbkit/io/text.hpp"
#include "dbbkit/iso230.hpp"
#include "dbbkit/kinematics.hpp"
#include "dbbkit/user_text.hpp"
#include "design_reader.hpp"
#include "object_reader.hpp"

namespace dbbkit::io {

using nlohmann::json;

namespace {

// A number or null.
std::optional<double> number_or_null(const json& v, const std::string& source,
                                     const std::string& path) {
  if (v.is_null()) return std::nullopt;
  return as_number(v, source, path);
}

const json& member(const json& obj, const std::string& key, const std::string& source,
                   const std::string& path) {
  if (!obj.is_object()) throw InputError(source, path, "expected an object");
  const auto it = obj.find(key);
  if (it == obj.end())
    throw InputError(source, path.empty() ? key : path + "." + key,
                     "missing: is this a result of dbbkit identify or diagnose (--out)?");
  return *it;
}

// A string within the text limits (user_text.hpp): a name's, or any other text's.
std::string text_of(const json& v, const std::string& source, const std::string& path,
                    std::size_t max_bytes = limits::kMaxTextBytes) {
  if (!v.is_string()) throw InputError(source, path, "expected a string");
  const std::string& s = v.get_ref<const std::string&>();
  if (const auto p = text_problem(s, max_bytes))
    throw InputError(source, path, quote_value(s) + ": " + *p);
  return s;
}

const json& list_of(const json& v, const std::string& source, const std::string& path) {
  if (!v.is_array()) throw InputError(source, path, "expected a list");
  return v;
}

// The largest value or uncertainty a result may hold [um, urad]: beyond it a number is not a
// machine's error (and sums of two would overflow).
constexpr double kMaxResultValue = 1e9;

std::optional<double> bounded(std::optional<double> v, const std::string& source,
                              const std::string& path, bool uncertainty) {
  if (!v) return v;
  if (!(std::abs(*v) <= kMaxResultValue))
    throw InputError(source, path, "beyond +-1e9 (um or urad): not a result of dbbkit");
  if (uncertainty && *v < 0) throw InputError(source, path, "is negative");
  return v;
}

using Names = std::vector<std::pair<std::string, std::string>>;  // name, unit

// A quantity whose name must be one of `names` and whose unit is the one the name takes.
ResultQuantity quantity(const json& q, const std::string& source, const std::string& path,
                        const Names& names) {
  ResultQuantity r;
  r.name = text_of(member(q, "name", source, path), source, path + ".name");
  const auto it =
      std::find_if(names.begin(), names.end(), [&](const auto& n) { return n.first == r.name; });
  if (it == names.end()) {
    std::string list;
    for (const auto& n : names) list += (list.empty() ? "" : ", ") + n.first;
    throw InputError(source, path + ".name",
                     quote_value(r.name) + " is not one of this axis' quantities (" + list + ")");
  }
  r.unit = text_of(member(q, "unit", source, path), source, path + ".unit");
  if (r.unit != it->second)
    throw InputError(source, path + ".unit",
                     quote_value(r.unit) + ": " + r.name + " is in " + it->second);
  r.value = bounded(number_or_null(member(q, "value", source, path), source, path + ".value"),
                    source, path + ".value", false);
  r.std = bounded(number_or_null(member(q, "std", source, path), source, path + ".std"), source,
                  path + ".std", true);
  if (r.value.has_value() != r.std.has_value())
    throw InputError(source, path, "a value without its std (or the other way round)");
  return r;
}

void no_repeats(const std::vector<ResultQuantity>& list, const std::string& source,
                const std::string& path) {
  std::set<std::string> seen;
  for (std::size_t i = 0; i < list.size(); ++i)
    if (!seen.insert(list[i].name).second)
      throw InputError(source, path + "[" + std::to_string(i) + "].name",
                       list[i].name + " is given twice");
}

double angle_of(const json& v, const std::string& source, const std::string& path) {
  const double a = as_number(v, source, path);
  if (!(std::abs(a) <= 36000)) throw InputError(source, path, "beyond +-36000 deg");
  return a;
}

}  // namespace

ResultFile result_from_text(const std::string& text, const std::string& source) {
  const json j = parse_json(text, source);
  ResultFile r;
  r.source = source;
  r.format = text_of(member(j, "format", source, ""), source, "format");
  if (r.format != "dbbkit.identify/1" && r.format != "dbbkit.diagnose/1")
    throw InputError(source, "format",
                     quote_value(r.format) +
                         " is not a result of dbbkit identify or diagnose (dbbkit.identify/1, "
                         "dbbkit.diagnose/1)");
  if (j.contains("inputs") && j["inputs"].is_object() && j["inputs"].contains("data") &&
      j["inputs"]["data"].is_string())
    r.data_source = j["inputs"]["data"].get<std::string>();
  const json& design = member(j, "design", source, "");
  r.design_name = text_of(member(design, "name", source, "design"), source, "design.name",
                          limits::kMaxNameBytes);
  r.errors_model =
      text_of(member(design, "errors_model", source, "design"), source, "design.errors_model");
  {
    // The axis as the design wrote it (the shorthand or the general form).
    const bool definition = design.contains("axis_definition");
    const json* form =
        definition ? &design["axis_definition"] : &member(design, "axis", source, "design");
    json holder = {{"axis", *form}};
    ObjectReader top(holder, source, "design");
    try {
      r.axis = read_axis(top);
    } catch (const InputError& e) {
      // Named as the result holds it.
      const std::string where = e.where();
      if (!definition || where.rfind("axis", 0) != 0) throw;
      throw InputError(e.source(), "design.axis_definition" + where.substr(4), e.detail());
    }
    // Both written: the label the definition gives.
    if (definition && design.contains("axis") && design["axis"].is_string() &&
        design["axis"].get<std::string>() != r.axis.label())
      throw InputError(source, "design.axis",
                       quote_value(design["axis"].get<std::string>(), 60) +
                           " is not the axis design.axis_definition describes (" + r.axis.label() +
                           ")");
  }
  if (j.contains("warnings")) {
    const json& w = j["warnings"];
    if (!w.is_array()) throw InputError(source, "warnings", "expected a list of {kind, text}");
    for (std::size_t k = 0; k < w.size(); ++k) {
      const std::string where = "warnings[" + std::to_string(k) + "]";
      r.warnings.push_back(text_of(member(w[k], "text", source, where), source, where + ".text"));
      r.warning_kinds.push_back(
          w[k].is_object() && w[k].contains("kind")
              ? text_of(w[k]["kind"], source, where + ".kind", limits::kMaxNameBytes)
              : std::string());
    }
  }
  if (!j.contains("iso230")) {
    throw InputError(source, "iso230",
                     r.format == "dbbkit.diagnose/1"
                         ? "missing: this diagnose result carries no ISO 230 quantities (written "
                           "by an earlier version); run diagnose again"
                         : "missing: is this a result of dbbkit identify (--out)?");
  }
  const json& iso = j["iso230"];
  // The names this axis' quantities take (iso230.hpp), with their units.
  const IsoNames names = iso230_names(r.axis);
  Names location_names, constant_names, motion_names;
  for (int k = 0; k < 5; ++k) {
    location_names.emplace_back(names.location[k], k < 2 ? "um" : "urad");
    constant_names.emplace_back(names.constants[k], k < 3 ? "um" : "urad");
  }
  for (int k = 0; k < 6; ++k) motion_names.emplace_back(names.components[k], kErrorUnits[k]);
  for (const auto& [key, out, allowed] :
       {std::tuple{"location", &r.location, &location_names},
        std::tuple{"constant_parts", &r.constants, &constant_names}}) {
    const std::string path = std::string("iso230.") + key;
    const json& list = list_of(member(iso, key, source, "iso230"), source, path);
    for (std::size_t i = 0; i < list.size(); ++i)
      out->push_back(quantity(list[i], source, path + "[" + std::to_string(i) + "]", *allowed));
    no_repeats(*out, source, path);
  }
  const json& comps =
      list_of(member(iso, "components", source, "iso230"), source, "iso230.components");
  std::set<double> component_angles;  // each angle once (a set: linear in the angles' number)
  for (std::size_t i = 0; i < comps.size(); ++i) {
    const std::string path = "iso230.components[" + std::to_string(i) + "]";
    ResultComponents c;
    c.angle_deg =
        angle_of(member(comps[i], "angle_deg", source, path), source, path + ".angle_deg");
    if (!component_angles.insert(c.angle_deg).second)
      throw InputError(source, path + ".angle_deg", "an angle given twice");
    for (const auto& [name, q] : comps[i].items()) {
      if (name == "angle_deg") continue;
      json named = q;
      if (!named.is_object()) throw InputError(source, path + "." + name, "expected an object");
      named["name"] = name;
      c.motions.push_back(quantity(named, source, path + "." + name, motion_names));
    }
    // ISO 230-1's order: the translations, then the rotations (the file's keys are sorted).
    auto rank = [&](const ResultQuantity& q) {
      return std::find_if(motion_names.begin(), motion_names.end(),
                          [&](const auto& n) { return n.first == q.name; }) -
             motion_names.begin();
    };
    std::stable_sort(
        c.motions.begin(), c.motions.end(),
        [&](const ResultQuantity& x, const ResultQuantity& y) { return rank(x) < rank(y); });
    r.components.push_back(std::move(c));
  }
  if (iso.contains("error_motion_values") && iso["error_motion_values"].contains("values")) {
    const json& m = iso["error_motion_values"];
    if (m.contains("coverage_probability")) {
      r.motion_coverage = as_number(m["coverage_probability"], source,
                                    "iso230.error_motion_values.coverage_probability");
      if (!(r.motion_coverage >= 0.5 && r.motion_coverage < 1))
        throw InputError(source, "iso230.error_motion_values.coverage_probability",
                         "must be in [0.5, 1)");
    }
    const json& list = list_of(m["values"], source, "iso230.error_motion_values.values");
    for (std::size_t i = 0; i < list.size(); ++i) {
      const std::string path = "iso230.error_motion_values.values[" + std::to_string(i) + "]";
      ResultMotionValue v;
      v.component = text_of(member(list[i], "component", source, path), source, path);
      const auto it = std::find_if(motion_names.begin(), motion_names.end(),
                                   [&](const auto& n) { return n.first == v.component; });
      if (it == motion_names.end())
        throw InputError(source, path + ".component",
                         quote_value(v.component) + " is not one of this axis' components");
      for (const ResultMotionValue& other : r.motion_values)
        if (other.component == v.component)
          throw InputError(source, path + ".component", v.component + " is given twice");
      v.name = text_of(member(list[i], "name", source, path), source, path + ".name");
      v.unit = text_of(member(list[i], "unit", source, path), source, path + ".unit");
      if (v.unit != it->second)
        throw InputError(source, path + ".unit",
                         quote_value(v.unit) + ": " + v.component + " is in " + it->second);
      v.value =
          bounded(number_or_null(member(list[i], "value", source, path), source, path + ".value"),
                  source, path + ".value", true);
      // A value not computed has no U (identify leaves it out and gives the reason).
      if (v.value) {
        v.U = bounded(number_or_null(member(list[i], "U", source, path), source, path + ".U"),
                      source, path + ".U", true);
        if (!v.U) throw InputError(source, path + ".U", "a value without its U");
      }
      r.motion_values.push_back(v);
    }
  }
  const json& errors = list_of(member(j, "errors", source, ""), source, "errors");
  std::set<double> error_angles;
  for (std::size_t i = 0; i < errors.size(); ++i) {
    const std::string path = "errors[" + std::to_string(i) + "]";
    ResultErrors e;
    e.angle_deg =
        angle_of(member(errors[i], "angle_deg", source, path), source, path + ".angle_deg");
    if (!error_angles.insert(e.angle_deg).second)
      throw InputError(source, path + ".angle_deg", "an angle given twice");
    const json& value = member(errors[i], "value", source, path);
    const json& std = member(errors[i], "std", source, path);
    for (int k = 0; k < 6; ++k) {
      const std::string vp = path + ".value." + kErrorNames[k];
      const std::string sp = path + ".std." + kErrorNames[k];
      e.value[k] = bounded(
          number_or_null(member(value, kErrorNames[k], source, path + ".value"), source, vp),
          source, vp, false);
      e.std[k] =
          bounded(number_or_null(member(std, kErrorNames[k], source, path + ".std"), source, sp),
                  source, sp, true);
      if (e.value[k].has_value() != e.std[k].has_value())
        throw InputError(source, vp, "a value without its std (or the other way round)");
    }
    r.errors.push_back(e);
  }
  if (j.contains("setup") && j["setup"].contains("included") && j["setup"]["included"].is_boolean())
    r.setup_included = j["setup"]["included"].get<bool>();
  if (iso.contains("uncertainty") && iso["uncertainty"].is_string())
    r.uncertainty_note = iso["uncertainty"].get<std::string>();
  // The covariance of the five location errors (a list of another length leaves it unread: chain
  // refuses such a result by its location list).
  if (iso.contains("location_covariance") && r.location.size() == 5) {
    const std::string path = "iso230.location_covariance";
    const json& names =
        list_of(member(iso["location_covariance"], "names", source, path), source, path + ".names");
    if (names.size() != 5)
      throw InputError(source, path + ".names", "expected the five location errors' names");
    const IsoNames iso_names = iso230_names(r.axis);
    for (std::size_t i = 0; i < 5; ++i)
      if (!names[i].is_string() || names[i].get<std::string>() != iso_names.location[i])
        throw InputError(source, path + ".names[" + std::to_string(i) + "]",
                         "expected " + iso_names.location[i] + " (ISO 230-1's order)");
    const json& m = list_of(member(iso["location_covariance"], "matrix", source, path), source,
                            path + ".matrix");
    if (m.size() != 5)
      throw InputError(source, path + ".matrix", "expected 5 rows, one per location error");
    Eigen::Matrix<double, 5, 5> c;
    for (int i = 0; i < 5; ++i) {
      const std::string row = path + ".matrix[" + std::to_string(i) + "]";
      const json& v = list_of(m[static_cast<std::size_t>(i)], source, row);
      if (v.size() != 5) throw InputError(source, row, "expected 5 entries");
      for (int k = 0; k < 5; ++k) {
        const std::string at = row + "[" + std::to_string(k) + "]";
        const auto x = number_or_null(v[static_cast<std::size_t>(k)], source, at);
        const bool determined = r.location[i].value && r.location[k].value;
        if (x.has_value() != determined)
          throw InputError(source, at,
                           determined ? "null where both location errors are determined"
                                      : "a number where a location error is not determined");
        c(i, k) = bounded(x, source, at, false).value_or(0.0);
      }
    }
    for (int i = 0; i < 5; ++i) {
      if (!r.location[i].std) continue;
      // The diagonal is each std squared (written with 6 decimals).
      const double s = *r.location[i].std;
      if (!(std::abs(std::sqrt(std::max(0.0, c(i, i))) - s) <= 1e-6 + 1e-6 * s))
        throw InputError(source,
                         path + ".matrix[" + std::to_string(i) + "][" + std::to_string(i) + "]",
                         "is not the square of " + r.location[i].name + "'s std");
    }
    if ((c - c.transpose()).cwiseAbs().maxCoeff() > 1e-9 * (1 + c.cwiseAbs().maxCoeff()))
      throw InputError(source, path + ".matrix", "not symmetric");
    // Written with 6 decimals: a covariance's smallest eigenvalue is then above -1e-6 of its
    // largest entry's size.
    const double lowest =
        Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, 5, 5>>(c, Eigen::EigenvaluesOnly)
            .eigenvalues()
            .minCoeff();
    if (lowest < -1e-6 * (1 + c.cwiseAbs().maxCoeff()))
      throw InputError(
          source, path + ".matrix",
          "not positive semidefinite (an eigenvalue " + fmt_num(lowest, 6) + "): not a covariance");
    r.location_covariance = c;
  }
  if (iso.contains("motion_covariance")) {
    const std::string path = "iso230.motion_covariance";
    const json& at =
        list_of(member(iso["motion_covariance"], "at", source, path), source, path + ".at");
    for (std::size_t i = 0; i < at.size(); ++i) {
      const std::string where = path + ".at[" + std::to_string(i) + "]";
      const double angle =
          angle_of(member(at[i], "angle_deg", source, where), source, where + ".angle_deg");
      const auto c = std::find_if(r.components.begin(), r.components.end(),
                                  [&](const ResultComponents& x) { return x.angle_deg == angle; });
      if (c == r.components.end())
        throw InputError(source, where + ".angle_deg", "not an angle of iso230.components");
      if (c->motion_covariance)
        throw InputError(source, where + ".angle_deg", "an angle given twice");
      if (!c->all_determined())
        throw InputError(source, where,
                         "a covariance where the component error motions are not all determined");
      // A 6 x 6 covariance: symmetric, positive semidefinite, each entry within 1e18.
      auto covariance_at = [&](const std::string& key) {
        const std::string path = where + "." + key;
        const json& m = list_of(member(at[i], key, source, where), source, path);
        if (m.size() != 6) throw InputError(source, path, "expected 6 rows");
        Eigen::Matrix<double, 6, 6> cov;
        for (int a = 0; a < 6; ++a) {
          const std::string row = path + "[" + std::to_string(a) + "]";
          const json& v = list_of(m[static_cast<std::size_t>(a)], source, row);
          if (v.size() != 6) throw InputError(source, row, "expected 6 entries");
          for (int b = 0; b < 6; ++b) {
            const std::string e = row + "[" + std::to_string(b) + "]";
            const double x = as_number(v[static_cast<std::size_t>(b)], source, e);
            if (!(std::abs(x) <= kMaxResultValue * kMaxResultValue))
              throw InputError(source, e, "beyond 1e18 (um^2, urad^2): not a result of dbbkit");
            cov(a, b) = x;
          }
        }
        const double top = cov.cwiseAbs().maxCoeff();
        if ((cov - cov.transpose()).cwiseAbs().maxCoeff() > 1e-9 * (1 + top))
          throw InputError(source, path, "not symmetric");
        for (int a = 0; a < 6; ++a)
          if (cov(a, a) < 0)
            throw InputError(source,
                             path + "[" + std::to_string(a) + "][" + std::to_string(a) + "]",
                             "a negative variance");
        const Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, 6, 6>> eig(cov);
        if (eig.eigenvalues().minCoeff() < -1e-9 * (1 + top))
          throw InputError(source, path,
                           "not positive semi-definite (an eigenvalue " +
                               std::to_string(eig.eigenvalues().minCoeff()) + ")");
        return cov;
      };
      const Eigen::Matrix<double, 6, 6> cov = covariance_at("matrix");
      if (at[i].is_object() && at[i].contains("errors_matrix"))
        c->errors_covariance = covariance_at("errors_matrix");
      // Each motion less its constant part is the location errors' part plus the component:
      // its std lies within the sum and the difference of theirs (the triangle inequality).
      if (r.location_covariance) {
        const Eigen::Matrix<double, 6, 5> G = location_motion(r.axis, angle);
        for (int e = 0; e < 6; ++e) {
          const double sq = std::sqrt(cov(e, e)), sc = *c->motions[e].std,
                       sg = std::sqrt(std::max(
                           0.0, (G.row(e) * *r.location_covariance * G.row(e).transpose())(0)));
          const double tol = 1e-5 * (1 + sg + sc) + 2e-6;
          if (sq > sg + sc + tol || sq < std::abs(sc - sg) - tol)
            throw InputError(
                source, where + ".matrix[" + std::to_string(e) + "][" + std::to_string(e) + "]",
                "a std of " + std::to_string(sq) + " does not fit " + c->motions[e].name +
                    "'s std " + std::to_string(sc) + " with the location errors' part's " +
                    std::to_string(sg));
        }
      }
      c->motion_covariance = cov;
    }
    if (iso["motion_covariance"].contains("independent_between_angles")) {
      const json& b = iso["motion_covariance"]["independent_between_angles"];
      if (!b.is_boolean())
        throw InputError(source, path + ".independent_between_angles", "expected true or false");
      r.independent_between_angles = b.get<bool>();
    }
    // Every angle whose six motions are determined has its entry: one left out would be
    // predicted from the location errors alone, as if it had not been measured.
    for (std::size_t i = 0; i < r.components.size(); ++i) {
      const ResultComponents& c = r.components[i];
      if (c.all_determined() && !c.motion_covariance)
        throw InputError(source, path + ".at",
                         "no entry for angle " + std::to_string(c.angle_deg) +
                             " deg, whose component motions are all determined");
    }
  }
  const bool type_a = j.contains("budget") && j["budget"].is_object() &&
                      j["budget"].contains("noise_evaluation") &&
                      j["budget"]["noise_evaluation"].is_string() &&
                      j["budget"]["noise_evaluation"].get<std::string>().rfind("Type A", 0) == 0;
  if (j.contains("budget") && j["budget"].is_object() && j["budget"].contains("values")) {
    const json& values = list_of(j["budget"]["values"], source, "budget.values");
    for (std::size_t i = 0; i < values.size(); ++i) {
      if (!values[i].is_object() || !values[i].contains("nu_eff") || values[i]["nu_eff"].is_null())
        continue;
      const std::string where = "budget.values[" + std::to_string(i) + "].nu_eff";
      const double nu = as_number(values[i]["nu_eff"], source, where);
      if (!(nu >= 1)) throw InputError(source, where, "degrees of freedom below 1");
      r.dof = r.dof ? std::min(*r.dof, nu) : nu;
    }
  }
  if (type_a && !r.dof)
    throw InputError(source, "budget.values",
                     "a Type A evaluation without the values' degrees of freedom (nu_eff)");
  if (design.contains("machine")) {
    const std::string path = "design.machine";
    const json& m = design["machine"];
    ResultFile::Machine rm;
    rm.name =
        text_of(member(m, "name", source, path), source, path + ".name", limits::kMaxNameBytes);
    rm.file = text_of(member(m, "file", source, path), source, path + ".file");
    rm.controller = text_of(member(m, "controller", source, path), source, path + ".controller");
    const std::string axis = text_of(member(m, "axis", source, path), source, path + ".axis");
    if (axis.size() != 1 || axis.find_first_of("ABC") != 0)
      throw InputError(source, path + ".axis", quote_value(axis) + " is not A, B or C");
    rm.axis = axis[0];
    if (rm.axis != r.axis.letter())
      throw InputError(source, path + ".axis",
                       "axis " + axis + ", but the result's axis is " + r.axis.label());
    const json& park = member(m, "park_deg", source, path);
    if (!park.is_object()) throw InputError(source, path + ".park_deg", "expected an object");
    for (const auto& [letter, angle] : park.items()) {
      if (letter.size() != 1 || letter.find_first_of("ABC") != 0 || letter[0] == rm.axis)
        throw InputError(source, path + ".park_deg." + letter, "not another rotary axis' letter");
      rm.park_deg[letter[0]] = angle_of(angle, source, path + ".park_deg." + letter);
    }
    const std::vector<double> o =
        read_numbers(member(m, "origin_mm", source, path), source, path + ".origin_mm");
    if (o.size() != 3 || !(std::abs(o[0]) <= 1e4 && std::abs(o[1]) <= 1e4 && std::abs(o[2]) <= 1e4))
      throw InputError(source, path + ".origin_mm", "expected [x, y, z] within +-10000 mm");
    rm.origin_mm = Eigen::Vector3d(o[0], o[1], o[2]);
    r.machine = rm;
  }
  return r;
}

ResultFile read_result_file(const std::string& path) {
  return result_from_text(read_json_file(path), path);
}

}  // namespace dbbkit::io
