// The cost gate: the work identify, evaluate and the worst case do on every committed design,
// counted (dbbkit/cost.hpp), against a committed baseline (benchmarks/cost-baseline.json).
// A count above its baseline fails and names the call, the design and the counter; a count
// below it is reported, to be recorded with --write. The counts are deterministic: the same
// on any machine at any speed, so the gate cannot drift as a timing would.
//
//   dbbkit_cost designs/*.json --baseline benchmarks/cost-baseline.json
//   dbbkit_cost designs/*.json --write benchmarks/cost-baseline.json
//
// Readings: the paper's measured data for the paper's designs (tests/data/paper), simulated
// readings of a zero truth at the declared noise (seed 1) for the others.

#include <cstdio>
#include <fstream>
#include <iostream>
#include <map>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "dbbkit/cost.hpp"
#include "dbbkit/identify.hpp"
#include "dbbkit/io/design_io.hpp"
#include "dbbkit/io/measurement_io.hpp"
#include "dbbkit/observability.hpp"
#include "dbbkit/parameterisation.hpp"
#include "dbbkit/simulate.hpp"

namespace {

using namespace dbbkit;
using Counts = std::map<std::string, long>;

template <typename F>
Counts counted(F&& f) {
  cost::reset();
  f();
  Counts out;
  for (const auto& [name, n] : cost::named(cost::counts())) out[name] = n;
  return out;
}

std::vector<Reading> readings_for(const std::string& path, const Design& d) {
  const std::string base = path.substr(path.find_last_of('/') + 1);
  const std::string data = std::string(DBBKIT_SOURCE_DIR) + "/tests/data/paper/";
  if (base == "paper-c-turntable.json")
    return io::read_measurement_file(data + "paper_c_turntable.csv", d);
  if (base == "paper-b-head.json") return io::read_measurement_file(data + "paper_b_head.csv", d);
  Truth t;
  t.model = d.errors;
  if (d.errors.kind == ErrorModel::Kind::kPerAngle) {
    for (const double a : d.angles_deg) t.per_angle.emplace_back(a, Vector6d::Zero());
  } else {
    const Parameterisation param(d);
    for (auto& c : t.coefficients)
      c.assign(static_cast<std::size_t>(param.n_axis_parameters() / 6), 0.0);
  }
  return simulate(d, t, 1);
}

}  // namespace

int main(int argc, char** argv) {
  std::vector<std::string> designs;
  std::string baseline, write;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if ((a == "--baseline" || a == "--write") && i + 1 < argc) {
      (a == "--baseline" ? baseline : write) = argv[++i];
    } else if (!a.empty() && a[0] != '-') {
      designs.push_back(a);
    } else {
      std::cerr << "usage: dbbkit_cost DESIGN.json... (--baseline FILE | --write FILE)\n";
      return 2;
    }
  }
  if (designs.empty() || baseline.empty() == write.empty()) {
    std::cerr << "usage: dbbkit_cost DESIGN.json... (--baseline FILE | --write FILE)\n";
    return 2;
  }
  std::map<std::string, Counts> now;
  for (const std::string& path : designs) {
    const Design d = io::read_design_file(path);
    const double L = d.reference_length_mm.value_or(100.0);
    const std::vector<Reading> readings = readings_for(path, d);
    IdentifyOptions options;
    options.iso_motion.enabled = false;  // a Monte Carlo: its draws are not the solver's work
    now["identify " + path] = counted([&] { identify(d, readings, options); });
    now["evaluate " + path] = counted([&] { evaluate_design(d, L); });
    now["worst_case " + path] = counted([&] { design_worst_case(d, L); });
    now["worst_total " + path] = counted([&] { design_worst_total(d, L); });
  }
  if (!write.empty()) {
    nlohmann::json j;
    j["format"] = "dbbkit.cost-baseline/1";
    j["cases"] = now;
    std::ofstream out(write);
    out << j.dump(2) << "\n";
    if (!out) {
      std::cerr << write << ": cannot write\n";
      return 2;
    }
    std::cout << "cost baseline written: " << now.size() << " cases, " << write << "\n";
    return 0;
  }
  std::ifstream in(baseline);
  nlohmann::json j;
  try {
    in >> j;
  } catch (const std::exception& e) {
    std::cerr << baseline << ": " << e.what() << "\n";
    return 2;
  }
  const std::map<std::string, Counts> base = j.at("cases").get<std::map<std::string, Counts>>();
  int above = 0, below = 0, missing = 0;
  for (const auto& [name, counts] : now) {
    const auto b = base.find(name);
    if (b == base.end()) {
      std::cout << "NEW     " << name << ": not in the baseline (record it with --write)\n";
      ++missing;
      continue;
    }
    for (const auto& [counter, n] : counts) {
      const auto was = b->second.find(counter);
      const long m = was == b->second.end() ? 0 : was->second;
      if (n > m) {
        std::cout << "MORE    " << name << ": " << counter << " " << n << " (baseline " << m
                  << ")\n";
        ++above;
      } else if (n < m) {
        std::cout << "less    " << name << ": " << counter << " " << n << " (baseline " << m
                  << ")\n";
        ++below;
      }
    }
  }
  std::cout << "cost gate: " << now.size() << " cases; " << above << " counts above the baseline, "
            << below << " below, " << missing << " new\n";
  if (below > 0 && above == 0 && missing == 0)
    std::cout << "the work fell: record it with dbbkit_cost ... --write " << baseline << "\n";
  return above > 0 || missing > 0 ? 1 : 0;
}
