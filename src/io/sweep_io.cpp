#include "dbbkit/io/sweep_io.hpp"

#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <sstream>

#include "dbbkit/effects.hpp"
#include "dbbkit/error.hpp"
#include "dbbkit/io/json_reader.hpp"
#include "dbbkit/user_text.hpp"

namespace dbbkit::io {

namespace {

// Largest number of values of one variable.
constexpr double kMaxSweepValues = 10000;

double parse_number(const std::string& text, const std::string& spec) {
  double x = 0;
  if (!parse_decimal(text, x))
    throw InputError("--sweep", quote_value(spec),
                     quote_value(text) + " is not a finite decimal number");
  return x;
}

}  // namespace

SweepVariable parse_sweep(const Design& design, const std::string& spec) {
  const auto eq = spec.find('=');
  if (eq == std::string::npos)
    throw InputError("--sweep", quote_value(spec),
                     "expected NAME=start:stop:step, e.g. L2=40:250:10");
  SweepVariable v;
  v.name = spec.substr(0, eq);
  if (v.name.empty() || std::string("LDH").find(v.name[0]) == std::string::npos) {
    throw InputError("--sweep", quote_value(spec), "the name must start with L, D or H");
  }
  v.coord = v.name[0] == 'L' ? 0 : v.name[0] == 'D' ? 1 : 2;
  if (v.coord == 2 && !design.axis.has_H())
    throw InputError("--sweep", quote_value(spec), "H is not used for the swinging head B");
  std::string rest = v.name.substr(1);
  if (!rest.empty() && rest[0] == '@') {
    std::istringstream ids(rest.substr(1));
    std::string id;
    while (std::getline(ids, id, ',')) {
      int i = design.find_installation(id);
      if (i < 0 && design.instrument == InstrumentKind::kProbe)  // a sphere: its channels (below)
        i = effect_installation(design, EffectKind::kPlacement, id);
      if (i < 0)
        throw InputError("--sweep", quote_value(spec),
                         "installation " + quote_value(id) + " is not in the design");
      v.installations.push_back(i);
    }
  } else {
    for (size_t i = 0; i < design.installations.size(); ++i) {
      if (design.installations[i].id.compare(0, rest.size(), rest) == 0)
        v.installations.push_back(static_cast<int>(i));
    }
  }
  if (v.installations.empty())
    throw InputError("--sweep", quote_value(spec),
                     "no installation of the design matches " + quote_value(rest));
  // A probe's sphere moves with all three of its channels.
  if (design.instrument == InstrumentKind::kProbe) {
    std::vector<int> whole;
    for (std::size_t i = 0; i < design.installations.size(); ++i) {
      for (int j : v.installations)
        if (design.installations[i].sphere ==
            design.installations[static_cast<std::size_t>(j)].sphere) {
          whole.push_back(static_cast<int>(i));
          break;
        }
    }
    v.installations = whole;
  }

  std::vector<std::string> parts;
  std::istringstream range(spec.substr(eq + 1));
  std::string part;
  while (std::getline(range, part, ':')) parts.push_back(part);
  if (parts.size() != 3) throw InputError("--sweep", quote_value(spec), "expected start:stop:step");
  const double start = parse_number(parts[0], spec), stop = parse_number(parts[1], spec),
               step = parse_number(parts[2], spec);
  if (!(step > 0) || stop < start)
    throw InputError("--sweep", quote_value(spec), "needs step > 0 and stop >= start");
  const double n = std::floor((stop - start) / step + 1e-9);
  if (n + 1 > kMaxSweepValues)
    throw InputError("--sweep", quote_value(spec), "more than 10000 values");
  for (long i = 0; i <= static_cast<long>(n); ++i)
    v.values.push_back(start + static_cast<double>(i) * step);
  return v;
}

nlohmann::json sweep_to_json(const std::vector<SweepVariable>& variables,
                             const std::vector<SweepPoint>& points) {
  using nlohmann::json;
  json vars = json::array();
  for (const SweepVariable& v : variables) {
    json ids = json::array();
    vars.push_back({{"name", v.name},
                    {"key", std::string("ball_mm.") + "LDH"[v.coord]},
                    {"installations", v.installations},
                    {"values", v.values}});
  }
  json grid = json::array();
  auto opt = [](const std::optional<double>& x) { return x ? json(*x) : json(nullptr); };
  for (const SweepPoint& p : points) {
    json g;
    for (size_t i = 0; i < variables.size(); ++i) g[variables[i].name] = p.values[i];
    g["rank"] = p.rank;
    g["n_unknowns"] = p.n_unknowns;
    g["condition_number"] = opt(p.condition_number);
    g["worst_std_um"] = opt(p.worst_std_um);
    g["worst_determined_std_um"] = opt(p.worst_determined_std_um);
    grid.push_back(g);
  }
  return {{"variables", vars}, {"grid", grid}};
}

std::string sweep_csv(const std::vector<SweepVariable>& variables,
                      const std::vector<SweepPoint>& points) {
  std::ostringstream s;
  for (const SweepVariable& v : variables) s << v.name << "_mm,";
  s << "rank,n_unknowns,condition_number,worst_std_um,worst_determined_std_um\n";
  auto opt = [&](const std::optional<double>& x) {
    if (x) s << *x;
  };
  for (const SweepPoint& p : points) {
    for (double x : p.values) s << x << ",";
    s << p.rank << "," << p.n_unknowns << ",";
    opt(p.condition_number);
    s << ",";
    opt(p.worst_std_um);
    s << ",";
    opt(p.worst_determined_std_um);
    s << "\n";
  }
  return s.str();
}

std::string sweep_summary(const std::vector<SweepVariable>& variables,
                          const std::vector<SweepPoint>& points) {
  std::ostringstream s;
  s << "\ndesign map: " << points.size() << " designs";
  const int best = best_sweep_point(points);
  if (best >= 0) {
    const SweepPoint& b = points[static_cast<std::size_t>(best)];
    s << "; smallest worst_std_um " << *b.worst_std_um << " um at";
    for (size_t i = 0; i < variables.size(); ++i)
      s << " " << variables[i].name << " = " << b.values[i];
  } else {
    s << "; none determines every error";
  }
  s << "\n";
  return s.str();
}

}  // namespace dbbkit::io
