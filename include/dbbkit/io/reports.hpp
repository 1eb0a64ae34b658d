#pragma once
// The report of each command: HTML (with plots) or Markdown (tables only), from
// the same sections written through one ReportWriter (report_writer.hpp). One source
// file per command: identify_report.cpp, evaluate_report.cpp, optimize_report.cpp,
// diagnose_report.cpp; the sections they share in report_sections.cpp.

#include <optional>
#include <string>
#include <vector>

#include "dbbkit/conformance.hpp"
#include "dbbkit/design.hpp"
#include "dbbkit/diagnose.hpp"
#include "dbbkit/identify.hpp"
#include "dbbkit/io/optimize_io.hpp"
#include "dbbkit/io/predict_io.hpp"
#include "dbbkit/io/report_writer.hpp"
#include "dbbkit/measurement.hpp"
#include "dbbkit/monte_carlo.hpp"
#include "dbbkit/observability.hpp"
#include "dbbkit/optimize.hpp"
#include "dbbkit/selection.hpp"
#include "dbbkit/setup_sheet.hpp"
#include "dbbkit/trace.hpp"

namespace dbbkit::io {

// What ran: the command line and the input files (hashed into the conditions).
struct RunContext {
  std::string command;
  std::vector<std::string> inputs;
};

std::string identify_report(ReportFormat f, const RunContext& run, const Design& design,
                            const std::vector<Reading>& readings, const IdentifyResult& result,
                            const MonteCarloResult* mc,
                            const ConformanceReport* conformance = nullptr);
// With `effects` (assess_design), the effects of diagnose's library the design cannot tell
// from the axis errors, and those its readings cannot carry, are listed.
std::string evaluate_report(ReportFormat f, const RunContext& run, const Design& design,
                            const Evaluation& ev, const std::vector<SweepVariable>& variables,
                            const std::vector<SweepPoint>& map, const MonteCarloResult* mc,
                            const Expansion& expansion,
                            const std::vector<CandidateStatus>* effects = nullptr);
// With `sheet`, the best design's set-up sheet closes the report.
std::string optimize_report(ReportFormat f, const RunContext& run, const Kit& kit,
                            const OptimizeResult& res, const std::optional<Reference>& reference,
                            double seconds, const Expansion& expansion,
                            const SetupSheet* sheet = nullptr);
std::string diagnose_report(ReportFormat f, const RunContext& run, const Design& design,
                            const std::vector<Reading>& readings, const DiagnoseResult& result,
                            const Expansion& expansion,
                            const ConformanceReport* conformance = nullptr);

// The report of `predict`: the largest error at each angle before and after entering, with U;
// over a map with evenly spaced radii and angles, a heat map of where it sits.
std::string predict_report(ReportFormat f, const RunContext& run, const PredictResult& p);

// One installation's trace and what `readings` found in it.
struct TraceRun {
  std::string installation, path;
  const Trace* trace = nullptr;
  const TraceReadings* found = nullptr;
};
// The report of `readings`: the warnings, then per installation the trace with its dwells
// marked (the samples averaged, at their mean) and a row per reading.
std::string readings_report(ReportFormat f, const RunContext& run, const Design& design,
                            const std::vector<TraceRun>& runs);

}  // namespace dbbkit::io
