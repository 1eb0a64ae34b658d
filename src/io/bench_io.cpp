#include "dbbkit/io/bench_io.hpp"

#include <cmath>
#include <iomanip>
#include <sstream>

#include "dbbkit/error.hpp"
#include "dbbkit/io/json_reader.hpp"
#include "dbbkit/io/report.hpp"
#include "dbbkit/io/result_io.hpp"

namespace dbbkit::io {

using nlohmann::json;

namespace {

std::string num(const std::optional<double>& v) { return fmt_opt(v, 5); }

std::optional<double> optional_value(ObjectReader& r, const std::string& key) {
  const json* v = r.optional(key);
  if (!v || v->is_null()) return std::nullopt;
  const double x = as_number(*v, r.source(), r.key_path(key));
  if (!(x > 0)) r.fail(key, "must be a positive number of um or null");
  return x;
}

}  // namespace

Baseline read_baseline_file(const std::string& path) {
  const json j = parse_json(read_text_file(path), path);
  ObjectReader top(j, path, "");
  const std::string format = top.string("format");
  if (format != kBaselineFormat) top.fail("format", "expected \"" + std::string(kBaselineFormat) + "\"");
  Baseline b;
  b.tolerance_relative = top.number("tolerance_relative");
  if (!(b.tolerance_relative >= 0 && b.tolerance_relative < 1)) {
    top.fail("tolerance_relative", "must be a fraction in [0, 1)");
  }
  const json& designs = top.required("designs");
  ObjectReader dr(designs, path, "designs");
  for (auto it = designs.begin(); it != designs.end(); ++it) {
    ObjectReader d = dr.object(it.key());
    BenchFigures f;
    f.rank = d.integer("rank");
    f.n_unknowns = d.integer("n_unknowns");
    if (f.rank < 0 || f.n_unknowns < f.rank) d.fail("rank", "must be between 0 and n_unknowns");
    f.worst_std_um = optional_value(d, "worst_std_um");
    f.worst_determined_std_um = optional_value(d, "worst_determined_std_um");
    f.worst_total_std_um = optional_value(d, "worst_total_std_um");
    f.worst_total_determined_std_um = optional_value(d, "worst_total_determined_std_um");
    d.finish();
    b.designs[it.key()] = f;
  }
  top.finish();
  return b;
}

json baseline_to_json(const Baseline& b) {
  json j;
  j["format"] = kBaselineFormat;
  j["tolerance_relative"] = b.tolerance_relative;
  json d = json::object();
  for (const auto& [key, f] : b.designs) {
    d[key] = {{"rank", f.rank},
              {"n_unknowns", f.n_unknowns},
              {"worst_std_um", optional_number(f.worst_std_um)},
              {"worst_determined_std_um", optional_number(f.worst_determined_std_um)}};
    if (f.worst_total_std_um || f.worst_total_determined_std_um) {
      d[key]["worst_total_std_um"] = optional_number(f.worst_total_std_um);
      d[key]["worst_total_determined_std_um"] = optional_number(f.worst_total_determined_std_um);
    }
  }
  j["designs"] = d;
  return j;
}

void judge(BenchRow& row, double tol) {
  if (!row.baseline) {
    row.status = "new";
    row.detail = "no baseline";
    return;
  }
  const BenchFigures& b = *row.baseline;
  const BenchFigures& n = row.now;
  std::vector<std::string> worse, better;
  const int lost_b = b.n_unknowns - b.rank, lost_n = n.n_unknowns - n.rank;
  if (n.n_unknowns != b.n_unknowns) {
    (n.n_unknowns > b.n_unknowns ? better : worse)
        .push_back("unknowns " + std::to_string(b.n_unknowns) + " -> " + std::to_string(n.n_unknowns));
  }
  if (lost_n > lost_b) worse.push_back("rank deficiency " + std::to_string(lost_b) + " -> " + std::to_string(lost_n));
  if (lost_n < lost_b) better.push_back("rank deficiency " + std::to_string(lost_b) + " -> " + std::to_string(lost_n));
  auto compare = [&](const char* what, const std::optional<double>& was, const std::optional<double>& is) {
    if (was && !is) {
      worse.push_back(std::string(what) + " " + num(was) + " um -> none");
    } else if (!was && is) {
      better.push_back(std::string(what) + " none -> " + num(is) + " um");
    } else if (was && is) {
      const double change = *is / *was - 1;
      if (change > tol) worse.push_back(std::string(what) + " " + num(was) + " -> " + num(is) + " um");
      if (change < -tol) better.push_back(std::string(what) + " " + num(was) + " -> " + num(is) + " um");
    }
  };
  compare("worst_std_um", b.worst_std_um, n.worst_std_um);
  if (!b.worst_std_um && !n.worst_std_um) {
    compare("worst_determined_std_um", b.worst_determined_std_um, n.worst_determined_std_um);
  }
  // The total with declared set-up tolerances: a design that now declares them needs a
  // baseline figure (the gate must guard what the design claims).
  const bool total_now = n.worst_total_std_um || n.worst_total_determined_std_um;
  const bool total_before = b.worst_total_std_um || b.worst_total_determined_std_um;
  if (total_now && !total_before) {
    worse.push_back("worst_total_std_um has no baseline (declared set-up tolerances): write the baseline");
  } else if (!total_now && total_before) {
    worse.push_back("worst_total_std_um in the baseline but the design declares no set-up tolerance");
  } else if (total_now) {
    compare("worst_total_std_um", b.worst_total_std_um, n.worst_total_std_um);
    if (!b.worst_total_std_um && !n.worst_total_std_um) {
      compare("worst_total_determined_std_um", b.worst_total_determined_std_um, n.worst_total_determined_std_um);
    }
  }
  auto join = [](const std::vector<std::string>& v) {
    std::string s;
    for (const std::string& x : v) {
      if (!s.empty()) s += "; ";
      s += x;
    }
    return s;
  };
  if (!worse.empty()) {
    row.status = "worse";
    row.detail = join(worse);
  } else if (!better.empty()) {
    row.status = "improved";
    row.detail = join(better) + " (update the baseline)";
  } else {
    row.status = "ok";
  }
}

std::string bench_table(const std::vector<BenchRow>& rows, double tol) {
  std::ostringstream s;
  size_t w = 6;
  for (const BenchRow& r : rows) w = std::max(w, r.key.size() + 2);
  s << std::left << std::setw(static_cast<int>(w)) << "design" << std::right << std::setw(5) << "axis"
    << std::setw(16) << "model" << std::setw(12) << "rank" << std::setw(14) << "worst [um]" << std::setw(14)
    << "baseline" << std::setw(12) << "cond" << std::setw(10) << "status" << "\n";
  for (const BenchRow& r : rows) {
    s << std::left << std::setw(static_cast<int>(w)) << r.key << std::right << std::setw(5) << r.axis
      << std::setw(16) << r.model << std::setw(12)
      << (std::to_string(r.now.rank) + "/" + std::to_string(r.now.n_unknowns));
    // A rank-deficient design shows its worst determined value in brackets.
    auto worst = [](const BenchFigures& f) {
      if (f.worst_std_um) return num(f.worst_std_um);
      if (!f.worst_determined_std_um) return std::string("--");
      std::ostringstream t;
      t << "(" << num(f.worst_determined_std_um) << ")";
      return t.str();
    };
    s << std::setw(14) << worst(r.now) << std::setw(14) << (r.baseline ? worst(*r.baseline) : "--") << std::setw(12)
      << fmt_opt(r.condition_number, 4) << std::setw(10) << r.status << "\n";
    if (r.now.worst_total_std_um || r.now.worst_total_determined_std_um) {
      s << "    total (noise and declared set-up): " << num(r.now.worst_total_std_um ? r.now.worst_total_std_um
                                                                                   : r.now.worst_total_determined_std_um)
        << " um";
      if (r.baseline && (r.baseline->worst_total_std_um || r.baseline->worst_total_determined_std_um)) {
        s << ", baseline "
          << num(r.baseline->worst_total_std_um ? r.baseline->worst_total_std_um : r.baseline->worst_total_determined_std_um)
          << " um";
      }
      s << "\n";
    }
    if (!r.detail.empty()) s << "    " << r.detail << "\n";
  }
  s << "(worst: worst_std_um, angular errors at each design's reference length; in brackets the worst determined "
       "value of a rank-deficient design; tolerance "
    << tol * 100 << " %)\n";
  return s.str();
}

}  // namespace dbbkit::io
