#include "dbbkit/io/bench_io.hpp"

#include <cmath>
#include <iomanip>
#include <sstream>

#include "dbbkit/error.hpp"
#include "dbbkit/io/json_reader.hpp"
#include "dbbkit/io/report_writer.hpp"
#include "dbbkit/io/result_io.hpp"
#include "dbbkit/io/text.hpp"
#include "dbbkit/user_text.hpp"
#include "object_reader.hpp"
#include "result_blocks.hpp"

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

const char* bench_state_name(BenchState s) {
  switch (s) {
    case BenchState::kOk:
      return "ok";
    case BenchState::kImproved:
      return "improved";
    case BenchState::kWorse:
      return "worse";
    case BenchState::kNew:
      return "new";
  }
  return "unknown";
}

Baseline read_baseline_file(const std::string& path) {
  const json j = parse_json(read_json_file(path), path);
  ObjectReader top(j, path, "");
  const std::string format = top.string("format");
  if (format != kBaselineFormat)
    top.fail("format", "expected \"" + std::string(kBaselineFormat) + "\"");
  Baseline b;
  b.tolerance_relative = top.number("tolerance_relative");
  if (!(b.tolerance_relative >= 0 && b.tolerance_relative < 1)) {
    top.fail("tolerance_relative", "must be a fraction in [0, 1)");
  }
  const json& designs = top.required("designs");
  ObjectReader dr(designs, path, "designs");
  for (auto it = designs.begin(); it != designs.end(); ++it) {
    // A key names a design file: text (user_text.hpp), printed and written as data.
    if (const auto problem = text_problem(it.key(), limits::kMaxTextBytes))
      throw InputError(path, "designs", "the key " + quote_value(it.key()) + ": " + *problem);
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
    row.state = BenchState::kNew;
    row.detail = "no baseline";
    return;
  }
  const BenchFigures& b = *row.baseline;
  const BenchFigures& n = row.now;
  std::vector<std::string> worse, better;
  const int lost_b = b.n_unknowns - b.rank, lost_n = n.n_unknowns - n.rank;
  if (n.n_unknowns != b.n_unknowns) {
    (n.n_unknowns > b.n_unknowns ? better : worse)
        .push_back("unknowns " + std::to_string(b.n_unknowns) + " -> " +
                   std::to_string(n.n_unknowns));
  }
  if (lost_n > lost_b)
    worse.push_back("rank deficiency " + std::to_string(lost_b) + " -> " + std::to_string(lost_n));
  if (lost_n < lost_b)
    better.push_back("rank deficiency " + std::to_string(lost_b) + " -> " + std::to_string(lost_n));
  auto compare = [&](const char* what, const std::optional<double>& was,
                     const std::optional<double>& is) {
    if (was && !is) {
      worse.push_back(std::string(what) + " " + num(was) + " um -> none");
    } else if (!was && is) {
      better.push_back(std::string(what) + " none -> " + num(is) + " um");
    } else if (was && is) {
      const double change = *is / *was - 1;
      if (change > tol)
        worse.push_back(std::string(what) + " " + num(was) + " -> " + num(is) + " um");
      if (change < -tol)
        better.push_back(std::string(what) + " " + num(was) + " -> " + num(is) + " um");
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
    worse.push_back(
        "worst_total_std_um has no baseline (declared set-up tolerances): write the baseline");
  } else if (!total_now && total_before) {
    worse.push_back(
        "worst_total_std_um in the baseline but the design declares no set-up tolerance");
  } else if (total_now) {
    compare("worst_total_std_um", b.worst_total_std_um, n.worst_total_std_um);
    if (!b.worst_total_std_um && !n.worst_total_std_um) {
      compare("worst_total_determined_std_um", b.worst_total_determined_std_um,
              n.worst_total_determined_std_um);
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
    row.state = BenchState::kWorse;
    row.detail = join(worse);
  } else if (!better.empty()) {
    row.state = BenchState::kImproved;
    row.detail = join(better) + " (update the baseline)";
  } else {
    row.state = BenchState::kOk;
  }
}

bool BenchRow::passed() const {
  for (const BenchCheck& c : checks) {
    if (!c.passed) return false;
  }
  return true;
}

void check_row(BenchRow& row, const BenchLimits& limits) {
  row.checks.clear();
  {
    BenchCheck c{"baseline", true, ""};
    if (row.state == BenchState::kWorse) {
      c.passed = false;
      c.message = "worse than the baseline: " + row.detail;
    } else if (row.state == BenchState::kNew) {
      c.passed = limits.allow_new;
      c.message = limits.allow_new
                      ? "no baseline (allowed: --allow-new)"
                      : "no baseline for this design: add it to the baseline, or pass --allow-new";
    } else {
      c.message = bench_state_name(row.state) + (row.detail.empty() ? "" : ": " + row.detail);
    }
    row.checks.push_back(c);
  }
  auto at_most = [&](const char* name, const std::optional<double>& limit,
                     const std::optional<double>& value, const std::string& unit,
                     const std::string& absent) {
    if (!limit) return;
    BenchCheck c{name, true, ""};
    if (!value) {
      c.passed = false;
      c.message = absent;
    } else {
      c.passed = *value <= *limit;
      c.message = num(value) + " " + unit + (c.passed ? " <= " : " > ") + num(limit) + " " + unit;
    }
    row.checks.push_back(c);
  };
  at_most("max_worst_std_um", limits.max_worst_std_um, row.now.worst_std_um, "um",
          "no worst_std_um: the design leaves errors undetermined");
  const bool declares = row.now.worst_total_std_um || row.now.worst_total_determined_std_um;
  at_most("max_worst_total_std_um", limits.max_worst_total_std_um, row.now.worst_total_std_um, "um",
          declares ? "no worst_total_std_um: the design leaves errors undetermined"
                   : "no worst_total_std_um: the design declares no set-up tolerance (setup_std)");
  at_most("max_time_s", limits.max_time_s, row.time_s, "s",
          "the design states no measurement time (predicted.time_s, written by optimize)");
}

std::string bench_junit(const std::vector<BenchRow>& rows) {
  int tests = 0, failures = 0;
  for (const BenchRow& r : rows) {
    for (const BenchCheck& c : r.checks) tests += 1, failures += !c.passed;
  }
  std::ostringstream s;
  s << "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n";
  s << "<testsuites name=\"dbbkit bench\" tests=\"" << tests << "\" failures=\"" << failures
    << "\" errors=\"0\">\n";
  s << "  <testsuite name=\"dbbkit bench\" tests=\"" << tests << "\" failures=\"" << failures
    << "\" errors=\"0\" skipped=\"0\">\n";
  for (const BenchRow& r : rows) {
    for (const BenchCheck& c : r.checks) {
      s << "    <testcase classname=\"" << xml_escape("bench." + r.key) << "\" name=\""
        << xml_escape(c.name) << "\" file=\"" << xml_escape(r.file) << "\"";
      if (c.passed) {
        s << ">\n      <system-out>" << xml_escape(c.message) << "</system-out>\n    </testcase>\n";
      } else {
        s << ">\n      <failure message=\"" << xml_escape(c.message) << "\" type=\""
          << xml_escape(c.name) << "\">" << xml_escape(r.file + ": " + c.message)
          << "</failure>\n    </testcase>\n";
      }
    }
  }
  s << "  </testsuite>\n</testsuites>\n";
  return s.str();
}

std::string bench_markdown(const std::vector<BenchRow>& rows, double tol,
                           const BenchLimits& limits) {
  int failed = 0, designs_failed = 0;
  for (const BenchRow& r : rows) {
    for (const BenchCheck& c : r.checks) failed += !c.passed;
    designs_failed += !r.passed();
  }
  std::ostringstream s;
  s << "# dbbkit bench: the design gate\n\n";
  s << rows.size() << " designs, " << designs_failed << " failed (" << failed
    << " failed checks). Tolerance against "
    << "the baseline " << tol * 100 << " %";
  if (limits.allow_new) s << "; designs without a baseline allowed";
  if (limits.max_worst_std_um)
    s << "; worst_std_um at most " << num(limits.max_worst_std_um) << " um";
  if (limits.max_worst_total_std_um)
    s << "; worst_total_std_um at most " << num(limits.max_worst_total_std_um) << " um";
  if (limits.max_time_s) s << "; time at most " << num(limits.max_time_s) << " s";
  s << ".\n\n";
  s << "| design | axis | model | rank | worst_std_um [um] | baseline [um] | worst_total_std_um "
       "[um] | result |\n";
  s << "|---|---|---|---:|---:|---:|---:|---|\n";
  for (const BenchRow& r : rows) {
    std::string result;
    for (const BenchCheck& c : r.checks) {
      if (!c.passed) result += (result.empty() ? "" : "; ") + c.name + ": " + c.message;
    }
    s << "| " << markdown_escape(r.key) << " | " << r.axis << " | " << markdown_escape(r.model)
      << " | " << r.now.rank << "/" << r.now.n_unknowns << " | " << num(r.now.worst_std_um) << " | "
      << (r.baseline ? num(r.baseline->worst_std_um) : std::string("--")) << " | "
      << (r.now.worst_total_std_um ? num(r.now.worst_total_std_um) : std::string("--")) << " | "
      << markdown_escape(result.empty() ? "pass (" + std::string(bench_state_name(r.state)) + ")"
                                        : "FAIL: " + result)
      << " |\n";
  }
  return s.str();
}

std::string bench_table(const std::vector<BenchRow>& rows, double tol) {
  std::ostringstream s;
  size_t w = 6;
  for (const BenchRow& r : rows) w = std::max(w, terminal_text(r.key).size() + 2);
  s << std::left << std::setw(static_cast<int>(w)) << "design" << std::right << std::setw(5)
    << "axis" << std::setw(16) << "model" << std::setw(12) << "rank" << std::setw(14)
    << "worst [um]" << std::setw(14) << "baseline" << std::setw(12) << "cond" << std::setw(10)
    << "status"
    << "\n";
  for (const BenchRow& r : rows) {
    s << std::left << std::setw(static_cast<int>(w)) << terminal_text(r.key) << std::right
      << std::setw(5) << r.axis << std::setw(16) << r.model << std::setw(12)
      << (std::to_string(r.now.rank) + "/" + std::to_string(r.now.n_unknowns));
    // A rank-deficient design shows its worst determined value in brackets.
    auto worst = [](const BenchFigures& f) {
      if (f.worst_std_um) return num(f.worst_std_um);
      if (!f.worst_determined_std_um) return std::string("--");
      std::ostringstream t;
      t << "(" << num(f.worst_determined_std_um) << ")";
      return t.str();
    };
    s << std::setw(14) << worst(r.now) << std::setw(14) << (r.baseline ? worst(*r.baseline) : "--")
      << std::setw(12) << fmt_opt(r.condition_number, 4) << std::setw(10)
      << (r.passed() ? bench_state_name(r.state) : "FAIL") << "\n";
    if (r.now.worst_total_std_um || r.now.worst_total_determined_std_um) {
      s << "    total (noise and declared set-up): "
        << num(r.now.worst_total_std_um ? r.now.worst_total_std_um
                                        : r.now.worst_total_determined_std_um)
        << " um";
      if (r.baseline &&
          (r.baseline->worst_total_std_um || r.baseline->worst_total_determined_std_um)) {
        s << ", baseline "
          << num(r.baseline->worst_total_std_um ? r.baseline->worst_total_std_um
                                                : r.baseline->worst_total_determined_std_um)
          << " um";
      }
      s << "\n";
    }
    if (!r.detail.empty()) s << "    " << r.detail << "\n";
    for (const BenchCheck& c : r.checks) {
      if (!c.passed && c.name != "baseline")
        s << "    FAIL " << c.name << ": " << c.message << "\n";
      if (!c.passed && c.name == "baseline" && r.state == BenchState::kNew)
        s << "    FAIL baseline: " << c.message << "\n";
    }
  }
  s << "(worst: worst_std_um, angular errors at each design's reference length; in brackets the "
       "worst determined "
       "value of a rank-deficient design; tolerance "
    << tol * 100 << " %)\n";
  return s.str();
}

}  // namespace dbbkit::io
