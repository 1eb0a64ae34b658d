#pragma once
// Two measurements of one axis compared (formats.md, "Comparing two results"): for every
// location error, constant part and error motion value, the change B - A, its standard
// uncertainty from both results' budgets (each with its set-up where its design declared one)
// and whether it is significant. The two results are treated as independent: each budget holds
// its own reading noise and set-up; what they share (the bar's calibration, a set-up left in
// place between them) cancels in the change and is in neither budget.
// Significance is family-wise at `level` over the m quantities compared (Bonferroni: each at
// level / m, two-sided, Gaussian), so that two measurements of an unchanged axis show a change
// with probability at most `level`. An error motion value's standard uncertainty is its
// expanded uncertainty over the Gaussian factor of its coverage (its Monte Carlo interval is
// nearly symmetric; said so).

#include <optional>
#include <string>
#include <vector>

#include "dbbkit/io/report_writer.hpp"
#include "dbbkit/io/reports.hpp"
#include "dbbkit/io/result_read.hpp"

namespace dbbkit::io {

struct ComparedQuantity {
  std::string kind;  // "location", "constant part", "error motion value"
  std::string name, unit;
  std::optional<double> a, b;       // the values (absent: not determined there)
  std::optional<double> change, u;  // B - A and its standard uncertainty
  bool significant = false;
};

// The errors at an angle both results have: the change and its standard uncertainty, per error
// (absent where either does not determine it). Not tested (the location errors and error motion
// values are what a change is decided on); shown and plotted.
struct ComparedErrors {
  double angle_deg = 0;
  std::array<std::optional<double>, 6> change, u;
};

// A warning of either input (its kind and text as the result holds them): A or B.
struct InputWarning {
  char result = 'A';
  std::string kind, text;
};

struct Comparison {
  ResultFile a, b;
  double level = 0.05;
  int tested = 0;  // m, the quantities with a change
  double z = 0;    // the two-sided factor at level / m
  std::vector<ComparedQuantity> quantities;
  std::vector<ComparedErrors> errors;  // at the common angles
  std::vector<std::string> notes;      // what differs between the two (design, set-up)
  // Each input's warnings, A's first; and, when any is there, what the significance of a change
  // assumes that they contradict (each result's uncertainty holding as stated).
  std::vector<InputWarning> input_warnings;
  std::optional<std::string> caveat;
  int significant() const;
};

// Throws InputError naming B's file when the two are of different axes.
Comparison compare_results(const ResultFile& a, const ResultFile& b, double level = 0.05);

nlohmann::json comparison_to_json(const Comparison& c);
std::string comparison_summary(const Comparison& c);
std::string comparison_report(ReportFormat format, const RunContext& run, const Comparison& c);

}  // namespace dbbkit::io
