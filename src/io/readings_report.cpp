#include <algorithm>
#include <memory>

#include "dbbkit/io/plots.hpp"
#include "dbbkit/io/report_writer.hpp"
#include "dbbkit/io/reports.hpp"
#include "dbbkit/io/text.hpp"
#include "report_sections.hpp"

namespace dbbkit::io {

using namespace detail;

namespace {

// The trace for a plot: the lowest and the highest sample of each of `buckets` equal stretches
// of time (a line through them keeps every excursion and the noise band).
PlotSeries envelope(const Trace& t, std::size_t buckets) {
  PlotSeries s;
  s.title = "trace";
  s.style = "lines";
  const std::size_t n = t.time_s.size();
  const std::size_t per = std::max<std::size_t>(1, n / buckets);
  for (std::size_t a = 0; a < n; a += per) {
    const std::size_t b = std::min(n, a + per);
    std::size_t lo = a, hi = a;
    for (std::size_t i = a; i < b; ++i) {
      if (t.reading_um[i] < t.reading_um[lo]) lo = i;
      if (t.reading_um[i] > t.reading_um[hi]) hi = i;
    }
    for (const std::size_t i : {std::min(lo, hi), std::max(lo, hi)}) {
      s.x.push_back(t.time_s[i]);
      s.y.push_back(t.reading_um[i]);
    }
  }
  return s;
}

}  // namespace

std::string readings_report(ReportFormat f, const RunContext& run, const Design& design,
                            const std::vector<TraceRun>& runs) {
  const std::unique_ptr<ReportWriter> page =
      make_report_writer(f, "dbbkit readings: " + design.name);
  ReportWriter& p = *page;
  std::vector<Warning> warnings;
  for (const TraceRun& r : runs)
    warnings.insert(warnings.end(), r.found->warnings.begin(), r.found->warnings.end());
  warnings_section(p, warnings);
  p.heading("Readings from the traces");
  std::size_t readings = 0;
  for (const TraceRun& r : runs) readings += r.found->readings.size();
  p.paragraph(std::to_string(readings) + " readings from " + std::to_string(runs.size()) +
              " traces: each the mean of a dwell's settled samples (after the move's transient, "
              "before the next move), its time the middle of those samples.");
  for (const TraceRun& r : runs) {
    const TraceReadings& found = *r.found;
    p.heading("Installation " + r.installation, 3);
    p.paragraph(r.path + ": " + std::to_string(r.trace->time_s.size()) + " samples every " +
                fmt_num(found.search.sample_interval_s, 3) + " s, sample noise " +
                fmt_num(found.search.noise_um, 3) +
                " um (the lower quartile of the 0.1 s windows' scatter), " +
                std::to_string(found.search.plateaus.size()) + " dwells.");
    PlotSeries dwells;
    dwells.title = "readings (settled mean)";
    dwells.style = "points";
    for (const Reading& g : found.readings) {
      dwells.x.push_back(*g.time_s);
      dwells.y.push_back(g.reading_um);
    }
    const Trace& trace = *r.trace;
    p.figure(
        [&] {
          return plot_series("installation " + r.installation, "time [s]", "reading [um]",
                             {envelope(trace, 2000), dwells}, 900, 320);
        },
        "The trace (the lowest and highest sample of each of 2,000 stretches) and each reading at "
        "the middle of the samples it averages.");
    std::vector<std::vector<std::string>> rows;
    for (const Reading& g : found.readings) {
      rows.push_back({fmt_num(g.angle_deg, 6), g.sweep ? sweep_name(*g.sweep) : "",
                      fmt_num(*g.time_s, 6), fmt_num(g.reading_um, 6), fmt_num(*g.std_um, 3),
                      std::to_string(*g.samples)});
    }
    p.table({"angle [deg]", "sweep", "time [s]", "reading [um]", "scatter [um]", "samples"}, rows);
  }
  conditions(p, run, &design);
  return p.str();
}

}  // namespace dbbkit::io
