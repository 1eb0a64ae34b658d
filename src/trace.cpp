#include "dbbkit/trace.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "dbbkit/effects.hpp"
#include "dbbkit/error.hpp"
#include "dbbkit/instrument.hpp"
#include "dbbkit/limits.hpp"
#include "dbbkit/program.hpp"
#include "dbbkit/user_text.hpp"
#include "number_text.hpp"
#include "random.hpp"

namespace dbbkit {

namespace {

// Mean and standard deviation of x[a, b) (two passes: exact for any offset of the values).
struct Moments {
  double mean = 0, std = 0;
};
Moments moments(const std::vector<double>& x, std::size_t a, std::size_t b) {
  Moments m;
  const std::size_t n = b - a;
  if (n == 0) return m;
  double s = 0;
  for (std::size_t i = a; i < b; ++i) s += x[i];
  m.mean = s / static_cast<double>(n);
  double q = 0;
  for (std::size_t i = a; i < b; ++i) q += (x[i] - m.mean) * (x[i] - m.mean);
  m.std = n > 1 ? std::sqrt(q / static_cast<double>(n - 1)) : 0.0;
  return m;
}

double median(std::vector<double> v) {
  if (v.empty()) return 0;
  const std::size_t mid = v.size() / 2;
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(mid), v.end());
  return v[mid];
}

std::string seconds(double t) { return text::significant(t, 6) + " s"; }

// The smallest noise the stillness test uses (um): a trace quantised without noise has none.
constexpr double kNoiseFloor_um = 0.005;
// The fewest samples of a stillness window, and the closest samples a trace may have.
constexpr double kMinWindowSamples = 20;
constexpr double kMinSampleInterval_s = 1e-6;

// The stillness test's window in samples at interval dt (at least kMinWindowSamples), and how far
// a still window's mean may lie from its neighbours' at this noise (mean_factor standard errors
// of the difference of two means, noise sqrt(2 / w)).
double window_samples(double dt, const DwellOptions& o) {
  return std::max(static_cast<double>(kMinWindowSamples), o.window_s / dt);
}
double mean_tolerance_um(double noise_um, double w, const DwellOptions& o) {
  return o.mean_factor * std::max(noise_um, kNoiseFloor_um) * std::sqrt(2.0 / w);
}

}  // namespace

double max_still_drift_um_per_min(double noise_um, double sample_interval_s,
                                  const DwellOptions& o) {
  const double w = std::round(window_samples(sample_interval_s, o));
  return 0.25 * mean_tolerance_um(noise_um, w, o) / (w * sample_interval_s) * 60.0;
}

double stillness_noise_um(double noise_um) { return std::max(noise_um, kNoiseFloor_um); }

long Trace::line_of(std::size_t i) const {
  const auto it = std::upper_bound(
      line_runs.begin(), line_runs.end(), i,
      [](std::size_t k, const std::pair<std::size_t, long>& run) { return k < run.first; });
  if (it == line_runs.begin() || std::prev(it)->second == 0) return 0;
  return std::prev(it)->second + static_cast<long>(i - std::prev(it)->first);
}

PlateauSearch find_plateaus(const Trace& trace, const DwellOptions& o, const std::string& source) {
  const std::vector<double>& t = trace.time_s;
  const std::vector<double>& x = trace.reading_um;
  const std::size_t n = t.size();
  if (n != x.size()) throw std::logic_error("find_plateaus: times and readings differ in number");
  if (n < 10) {
    throw InputError(source, "", "a trace needs at least 10 samples, found " + std::to_string(n));
  }
  if (n > limits::kMaxTraceSamples) {
    throw InputError(source, "",
                     std::to_string(n) + " samples, more than the " +
                         std::to_string(limits::kMaxTraceSamples) +
                         " one trace may hold (docs/formats.md, \"Limits\")");
  }
  for (std::size_t i = 0; i < n; ++i) {
    if (!std::isfinite(t[i]) || !std::isfinite(x[i]))
      throw InputError(source, "sample " + std::to_string(i + 1), "not a finite number");
    if (std::abs(x[i]) > limits::kMaxTraceReading_um) {
      throw InputError(
          source, "sample " + std::to_string(i + 1),
          "the reading " + text::significant(x[i], 6) + " um is beyond the limit of a reading (+-" +
              text::significant(limits::kMaxTraceReading_um, 6) + " um, README \"Limits\")");
    }
    if (i > 0 && !(t[i] > t[i - 1])) {
      throw InputError(
          source, "sample " + std::to_string(i + 1),
          "the time " + seconds(t[i]) + " does not increase (after " + seconds(t[i - 1]) + ")");
    }
  }
  if (!(o.dwell_s > 0 && o.min_share > 0 && o.min_share <= 1 && o.window_s > 0 &&
        o.scatter_factor > 0 && o.mean_factor > 0 && o.settle_window_s > 0))
    throw std::logic_error("find_plateaus: options out of range");
  PlateauSearch out;
  {
    std::vector<double> dt(n - 1);
    for (std::size_t i = 1; i < n; ++i) dt[i - 1] = t[i] - t[i - 1];
    out.sample_interval_s = median(dt);
  }
  const double dt = out.sample_interval_s;
  // Milliseconds since 1970 read as seconds: times beyond 1e9 s (31 years) in steps of 0.5 or
  // more.
  if (t[0] > 1e9 && dt >= 0.5) {
    throw InputError(source, "",
                     "the times look like milliseconds since 1970 (the first " +
                         text::significant(t[0], 15) + ", " + seconds(dt) +
                         " apart): the time column is seconds from the trace's start (give the "
                         "sample index with " +
                         option_name("--sample-rate-hz") + ", or convert)");
  }
  // A clock jump, or two recordings joined.
  for (std::size_t i = 1; i < n; ++i) {
    const double gap = t[i] - t[i - 1];
    if (gap > limits::kMaxTraceGap_s && gap > limits::kMaxTraceGapFactor * dt) {
      throw InputError(
          source, "sample " + std::to_string(i + 1),
          "the time jumps by " + seconds(gap) + " (from " + text::significant(t[i - 1], 12) +
              " s to " + text::significant(t[i], 12) + " s), more than " +
              text::significant(limits::kMaxTraceGapFactor, 6) + " times the median interval " +
              seconds(dt) + " and more than " + seconds(limits::kMaxTraceGap_s) +
              ": a clock jump or two recordings joined; a trace is one installation's "
              "recording");
    }
  }
  if (!(dt >= kMinSampleInterval_s)) {
    throw InputError(source, "",
                     "the samples are " + seconds(dt) +
                         " apart (median): below 1 us, a rate above 1 MHz; check the time "
                         "column's unit (or " +
                         option_name("--sample-rate-hz") + ")");
  }
  // A window of the stillness test longer than the whole dwell: every still window would pass
  // for a dwell. Samples a second or more apart are most likely milliseconds read as seconds.
  if (kMinWindowSamples * dt > o.dwell_s) {
    throw InputError(
        source, "",
        "the samples are " + seconds(dt) + " apart (median): a window of " +
            text::significant(kMinWindowSamples, 6) + " samples (" +
            seconds(kMinWindowSamples * dt) + ") is longer than a dwell of " + seconds(o.dwell_s) +
            " (" + option_name("--dwell-s") + "), no dwell can be told" +
            (dt >= 0.5
                 ? "; the times look like milliseconds (a sample every " +
                       text::significant(dt, 6) + " ms is " + text::significant(1000.0 / dt, 6) +
                       " Hz): the time column is seconds from the trace's start (convert "
                       "it, or give the sample index with " +
                       option_name("--sample-rate-hz") + ")"
                 : ": a trace is sampled at 20 Hz or more (a QC20-W at 1 kHz)"));
  }
  // Consecutive windows of w samples (at least kMinWindowSamples, so that each window's mean and
  // scatter are estimates): their means and scatters.
  const double per_window = window_samples(dt, o);
  if (per_window * 4 > static_cast<double>(n)) {
    throw InputError(source, "",
                     "a trace of " + std::to_string(n) + " samples every " + seconds(dt) +
                         " is too short to find dwells in (fewer than four windows of " +
                         text::significant(std::round(per_window), 6) + " samples)");
  }
  const auto w = static_cast<std::size_t>(std::round(per_window));
  const std::size_t blocks = n / w;
  std::vector<Moments> block(blocks);
  for (std::size_t b = 0; b < blocks; ++b) block[b] = moments(x, b * w, (b + 1) * w);
  // The sample noise: the lower quartile of the windows' scatters (the still ones, when a quarter
  // of the trace or more is still: the scatter of white noise over a window varies by a few per
  // cent, a moving bar's is larger), unless given.
  if (o.noise_um) {
    out.noise_um = *o.noise_um;
  } else {
    std::vector<double> scatter(blocks);
    for (std::size_t b = 0; b < blocks; ++b) scatter[b] = block[b].std;
    if (!scatter.empty()) {
      const std::size_t q = scatter.size() / 4;
      std::nth_element(scatter.begin(), scatter.begin() + static_cast<std::ptrdiff_t>(q),
                       scatter.end());
      out.noise_um = scatter[q];
    }
  }
  const double noise = std::max(out.noise_um, kNoiseFloor_um);
  // Still: the window's scatter within the noise, and its mean within the noise of the means of
  // its neighbours (a bar moving at a fraction of a um/s changes the mean from window to window
  // long before it widens a window's scatter).
  const double mean_tol = mean_tolerance_um(noise, static_cast<double>(w), o);
  std::vector<char> still(blocks, 0);
  for (std::size_t b = 0; b < blocks; ++b) {
    const bool quiet = block[b].std <= o.scatter_factor * noise;
    const bool before = b == 0 || std::abs(block[b].mean - block[b - 1].mean) <= mean_tol;
    const bool after = b + 1 == blocks || std::abs(block[b + 1].mean - block[b].mean) <= mean_tol;
    still[b] = quiet && before && after;
  }
  const double min_length_s = o.min_share * o.dwell_s;
  const auto m = static_cast<std::size_t>(
      std::min(static_cast<double>(w), std::max(3.0, std::round(o.settle_window_s / dt))));
  for (std::size_t b = 0; b < blocks;) {
    if (!still[b]) {
      ++b;
      continue;
    }
    std::size_t e = b;
    while (e < blocks && still[e]) ++e;
    const std::size_t a = b * w, z = e * w;  // samples [a, z)
    b = e;
    if (t[z - 1] - t[a] + dt < min_length_s) continue;
    Plateau p;
    p.start_s = t[a];
    p.end_s = t[z - 1];
    // The end: one window before the run's end (the next move's onset); the level: the mean of
    // the second half of what is left; the start: the first smoothing block from which every
    // block mean stays within the noise of that level.
    const std::size_t end = z - std::min(w, (z - a) / 4);
    const double level = moments(x, a + (end - a) / 2, end).mean;
    const double tol = 4.0 * noise / std::sqrt(static_cast<double>(m));
    std::size_t start = a;
    for (std::size_t k = a; k + m <= end; k += m) {
      if (std::abs(moments(x, k, k + m).mean - level) > tol) start = k + m;
    }
    if (end - start < 2 * m) start = a + (end - a) / 2;  // never settled: the second half, warned
    const Moments s = moments(x, start, end);
    p.settled_start_s = t[start];
    p.settled_end_s = t[end - 1];
    p.level_um = s.mean;
    p.std_um = s.std;
    p.samples = static_cast<long>(end - start);
    p.first_sample = start;
    out.plateaus.push_back(p);
  }
  return out;
}

std::vector<Stop> program_stops(const Design& design, int installation,
                                const std::vector<Sweep>& sweeps) {
  std::vector<Stop> stops;
  for (const Sweep s : sweeps) {
    for (const SweepReading& r : sweep_readings(design, installation, s)) {
      if (!stops.empty() && stops.back().angle_deg == r.angle_deg) {
        stops.back().sweeps.push_back(r.approach);  // no move between: one stop
      } else {
        stops.push_back({r.angle_deg, {r.approach}});
      }
    }
  }
  return stops;
}

std::vector<Sweep> sweeps_by_name(const std::string& name, const std::string& source) {
  if (const auto s = program_sweeps_named(name)) return program_sweeps(*s);
  // A list in order, as a truth's schedule.sweeps: "ccw,cw,ccw".
  std::vector<Sweep> out;
  for (std::size_t i = 0; name.find(',') != std::string::npos && i <= name.size();) {
    const std::size_t e = std::min(name.find(',', i), name.size());
    const std::string part = name.substr(i, e - i);
    if (part != "ccw" && part != "cw") break;
    out.push_back(part == "cw" ? Sweep::kCW : Sweep::kCCW);
    if (e == name.size()) {
      if (out.size() <= limits::kMaxSweeps) return out;
      throw InputError(source, "",
                       "more than " + std::to_string(limits::kMaxSweeps) + " sweeps in the list");
    }
    i = e + 1;
  }
  throw InputError(
      source, "",
      quote_value(name) + " is not ccw, cw, both or a list of them in order (ccw,cw,ccw)");
}

namespace {
// A dwell's level beyond the instrument's range: refused at the dwell's first sample (its line
// and column, when read from a file), the unit of the column named as the likely cause.
[[noreturn]] void beyond_range(const Design& design, const Trace& trace, std::size_t sample,
                               const std::string& dwell, double level_um,
                               const std::string& source) {
  const long line = trace.line_of(sample);
  const std::string at =
      line > 0 ? "line " + std::to_string(line) + ", column " + quote_value(trace.reading_column)
               : "sample " + std::to_string(sample + 1);
  const bool mm = trace.reading_unit == "mm";
  const std::string range = text::significant(design.instrument_range_mm, 6);
  throw InputError(source, at,
                   dwell + ": its level " +
                       (mm ? text::significant(level_um / 1000.0, 6) + " mm"
                           : text::significant(level_um, 6) + " um") +
                       " is beyond the instrument's range of +-" + range +
                       " mm (the design's instrument.range_mm)" +
                       (mm ? ": are the readings in um? (a column reading_um, or " +
                                 option_with_value("--unit", "um") + ")"
                        : trace.reading_unit == "um"
                            ? ": is the column's unit right? (um: reading_um, or " +
                                  option_with_value("--unit", "um") + "; mm: reading_mm, or " +
                                  option_with_value("--unit", "mm") + ")"
                            : ": are the readings in um?"));
}
}  // namespace

void check_trace_installation(const Design& design, const std::string& installation) {
  require_ballbar(design, "design", "a reading from a trace");
  if (design.find_installation(installation) >= 0) return;
  std::string ids, other_case;
  auto lower = [](std::string x) {
    for (char& c : x) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    return x;
  };
  for (std::size_t i = 0; i < design.installations.size(); ++i) {
    const std::string& id = design.installations[i].id;
    if (i < 20) ids += (i ? ", " : "") + id;
    if (other_case.empty() && lower(id) == lower(installation)) other_case = id;
  }
  if (design.installations.size() > 20) ids += ", ...";
  throw InputError(
      option_name("--trace"), quote_value(installation),
      "no installation of the design has this id" +
          (other_case.empty() ? std::string()
                              : " (ids are case-sensitive: " + quote_value(other_case) + "?)") +
          "; its installations: " + ids);
}

TraceReadings readings_from_trace(const Design& design, const std::string& installation,
                                  const Trace& trace, const std::vector<Sweep>& sweeps,
                                  const DwellOptions& options, const std::string& source) {
  check_trace_installation(design, installation);
  TraceReadings out;
  out.search = find_plateaus(trace, options, source);
  const std::vector<Plateau>& P = out.search.plateaus;
  const int index = design.find_installation(installation);
  const std::vector<Stop> stops = program_stops(design, index, sweeps);
  // The program stands at its first angle from the bar's mounting to the first reading: a trace
  // recorded from its start begins still. One that begins moving started during a move, its
  // first stop's dwell lost (or too short to be one); its dwells then match the stops in number
  // only when a dwell after the last stop (the return home) makes up for it.
  std::string moving;
  if (!P.empty() && P[0].start_s > trace.time_s.front()) {
    moving = "the trace moves for " + seconds(P[0].start_s - trace.time_s.front()) +
             " before its first dwell at " + seconds(P[0].start_s) +
             ": the recording may have started during a move";
  }
  if (P.size() != stops.size()) {
    std::string found;
    for (std::size_t k = 0; k < P.size() && k < 40; ++k) {
      found += (k ? ", " : "") + text::significant(P[k].start_s, 6) + "-" +
               text::significant(P[k].end_s, 6);
    }
    if (P.size() > 40) found += ", ...";
    throw InputError(
        source, "installation " + installation,
        "found " + std::to_string(P.size()) + " dwells, the sweep" +
            (sweeps.size() > 1 ? "s have " : " has ") + std::to_string(stops.size()) + " stops (" +
            std::to_string(design.angles_of(index).size()) + " angles" +
            (sweeps.size() == 2  ? ", both sweeps"
             : sweeps.size() > 2 ? ", " + std::to_string(sweeps.size()) + " sweeps"
                                 : std::string()) +
            "); dwells found (s): " + (found.empty() ? "none" : found) + ". Check " +
            option_name("--dwell-s") + " (the program's dwell), " + option_name("--sweeps") +
            ", that the trace is this "
            "installation's whole run (a move must show in the bar's length) and "
            "that the bar drifts by less than about " +
            text::significant(max_still_drift_um_per_min(out.search.noise_um,
                                                         out.search.sample_interval_s, options),
                              2) +
            " um/min (at the sample noise found, " +
            text::significant(stillness_noise_um(out.search.noise_um), 2) +
            " um, a faster drift is often not still)" + (moving.empty() ? "" : "; " + moving));
  }
  if (!moving.empty()) {
    throw InputError(
        source, "installation " + installation,
        moving + ", the first stop's dwell (" + text::significant(stops[0].angle_deg, 6) +
            " deg) not in it, and the last dwell (" + text::significant(P.back().start_s, 6) + "-" +
            text::significant(P.back().end_s, 6) +
            " s) may be the return home: every reading would be one angle off. Record from "
            "before the program's start (the machine standing at the first angle), or, if the "
            "first dwell is the first stop's, cut the samples before it");
  }
  const double noise = std::max(out.search.noise_um, kNoiseFloor_um);
  for (std::size_t k = 0; k < P.size(); ++k) {
    const Plateau& p = P[k];
    const Stop& stop = stops[k];
    const std::size_t parts = stop.sweeps.size();
    const std::string where = "installation " + installation + ", dwell " + std::to_string(k + 1) +
                              " at " + text::significant(stop.angle_deg, 6) + " deg (" +
                              text::significant(p.start_s, 6) + "-" +
                              text::significant(p.end_s, 6) + " s)";
    // The settled samples, split into equal parts for a stop of several readings.
    const std::size_t first = p.first_sample;
    const std::size_t count = static_cast<std::size_t>(p.samples);
    for (std::size_t q = 0; q < parts; ++q) {
      const std::size_t a = first + count * q / parts, b = first + count * (q + 1) / parts;
      const Moments s = moments(trace.reading_um, a, b);
      Reading r;
      r.installation = installation;
      r.angle_deg = stop.angle_deg;
      r.reading_um = s.mean;
      r.time_s = 0.5 * (trace.time_s[a] + trace.time_s[b - 1]);
      r.sweep = stop.sweeps[q];
      r.std_um = s.std;
      r.samples = static_cast<int>(b - a);
      // Type A of the mean by batch means (the samples are correlated over the servo's and the
      // instrument's time constants; batches of 0.1 s, at least 20 samples, are nearly not).
      const double dt = (trace.time_s[b - 1] - trace.time_s[a]) / static_cast<double>(b - a - 1);
      const std::size_t batch =
          std::max<std::size_t>(20, static_cast<std::size_t>(std::llround(0.1 / dt)));
      const std::size_t batches = (b - a) / batch;
      if (batches >= 2) {
        std::vector<double> means;
        for (std::size_t j = 0; j < batches; ++j)
          means.push_back(moments(trace.reading_um, a + j * batch, a + (j + 1) * batch).mean);
        const Moments m = moments(means, 0, batches);
        r.u_a_um = m.std / std::sqrt(static_cast<double>(batches));
        r.u_a_dof = static_cast<int>(batches) - 1;
      }
      if (std::abs(r.reading_um) > 1000.0 * design.instrument_range_mm)
        beyond_range(design, trace, a, where, r.reading_um, source);
      out.readings.push_back(r);
    }
    const bool inner = k > 0 && k + 1 < P.size();  // the first and last are of unknown length
    const double length = p.end_s - p.start_s;
    if (p.std_um > 1.4 * noise) {
      out.warnings.push_back(
          {"trace_scatter", where + ": its scatter " + text::significant(p.std_um, 3) +
                                " um is more than 1.4 times the trace's sample noise " +
                                text::significant(noise, 3) +
                                " um: the machine may not have stood still"});
    }
    if (inner && length > 1.5 * options.dwell_s * static_cast<double>(parts) + 1.0) {
      out.warnings.push_back(
          {"trace_length", where + ": " + text::significant(length, 3) + " s long against a " +
                               text::significant(options.dwell_s * static_cast<double>(parts), 3) +
                               " s dwell: a pause, or two stops without a move between them"});
    }
    if (p.settled_end_s - p.settled_start_s < 0.25 * options.dwell_s * static_cast<double>(parts)) {
      out.warnings.push_back(
          {"trace_settling", where + ": settled for only " +
                                 text::significant(p.settled_end_s - p.settled_start_s, 3) +
                                 " s: the reading rests on few samples"});
    }
  }
  return out;
}

SimulatedTrace simulate_trace(const std::vector<Stop>& stops, const std::vector<double>& levels,
                              const TraceSimulation& o, const std::vector<double>& times_s) {
  std::size_t readings = 0;
  for (const Stop& s : stops) readings += s.sweeps.size();
  if (readings != levels.size() || !(times_s.empty() || times_s.size() == readings))
    throw std::logic_error("simulate_trace: one level (and time) per reading of the stops");
  if (!(o.rate_hz > 0 && o.dwell_s > 0 && o.move_s_min > 0 && o.move_s_max >= o.move_s_min))
    throw std::logic_error("simulate_trace: options out of range");
  detail::Xoshiro256pp rng(o.seed);
  const detail::NormalZiggurat normal;
  SimulatedTrace out;
  const double dt = 1.0 / o.rate_hz;
  double t = 0;
  // The settling oscillation left by the last move: amplitude, phase and when it began.
  double settle = 0, settle_from = 0;
  auto sample = [&](double level, double extra) {
    double x = level + extra + o.drift_um_per_min * t / 60.0 + o.noise_um * normal(rng);
    if (settle != 0) {
      const double u = t - settle_from;
      x += settle * std::exp(-u / o.settle_tau_s) * std::cos(2 * M_PI * o.settle_hz * u);
    }
    if (o.resolution_um > 0) x = o.resolution_um * std::round(x / o.resolution_um);
    out.trace.time_s.push_back(t);
    out.trace.reading_um.push_back(x);
    t += dt;
  };
  auto hold = [&](double level, double seconds) {
    const auto n = static_cast<long>(std::llround(seconds * o.rate_hz));
    for (long i = 0; i < n; ++i) sample(level, 0);
  };
  // With times (the test's clock): each move centred between the last reading of one stop and
  // the first of the next; each plateau from the end of one move to the start of the next, the
  // first and the last as long again beyond their readings' middle; the trace's zero where the
  // first plateau begins (not before the test clock's zero). The moves' durations come from a
  // generator of their own.
  const bool timed = !times_s.empty();
  const std::size_t K = stops.size();
  std::vector<double> move_T(K, 0.0), end_at(K, 0.0);  // end_at: a plateau's end, trace clock
  if (timed) {
    detail::Xoshiro256pp moves(o.seed ^ 0x9e3779b97f4a7c15ULL);
    std::vector<double> first(K), last(K), begin(K), end(K);
    std::size_t i = 0;
    for (std::size_t k = 0; k < K; ++k) {
      first[k] = times_s[i];
      i += stops[k].sweeps.size();
      last[k] = times_s[i - 1];
      if (k > 0) move_T[k] = o.move_s_min + (o.move_s_max - o.move_s_min) * moves.uniform01();
    }
    for (std::size_t k = 0; k < K; ++k) {
      if (k > 0) begin[k] = 0.5 * (last[k - 1] + first[k]) + 0.5 * move_T[k];
      if (k + 1 < K) end[k] = 0.5 * (last[k] + first[k + 1]) - 0.5 * move_T[k + 1];
    }
    const double dwell0 = o.dwell_s * static_cast<double>(stops[0].sweeps.size());
    const double m0 = 0.5 * (first[0] + last[0]), mK = 0.5 * (first[K - 1] + last[K - 1]);
    if (K == 1) end[0] = mK + 0.5 * dwell0 + o.last_extra_s;
    begin[0] = 2 * m0 - end[0];
    if (K > 1) end[K - 1] = 2 * mK - begin[K - 1];
    for (std::size_t k = 0; k < K; ++k) {
      const double need = o.dwell_s * static_cast<double>(stops[k].sweeps.size());
      if (end[k] - begin[k] < need) {
        throw InputError("schedule", "per_reading_s",
                         "the schedule leaves " + text::significant(end[k] - begin[k], 3) +
                             " s at the stop at " + text::significant(stops[k].angle_deg, 6) +
                             " deg, less than its dwell of " + text::significant(need, 3) +
                             " s beside moves of up to " + text::significant(o.move_s_max, 3) +
                             " s: a trace cannot follow it (raise per_reading_s or lower "
                             "--trace-dwell-s)");
      }
    }
    out.zero_s = std::max(0.0, begin[0]);
    out.shortest_dwell_s = std::numeric_limits<double>::infinity();
    for (std::size_t k = 0; k < K; ++k) {
      end_at[k] = end[k] - *out.zero_s;
      const double length = end[k] - std::max(begin[k], *out.zero_s);
      // The first and last may be of any length beyond the dwell, but are found only when at
      // least half of it long (min_share), less the windows the next move's onset takes (up to
      // three of 0.1 s or 20 samples): the first is cut where the test's clock begins.
      const double window = std::max(0.1, 20.0 / o.rate_hz);
      *out.shortest_dwell_s = std::min(*out.shortest_dwell_s,
                                       K > 2 && (k == 0 || k + 1 == K)
                                           ? 1.8 * (length - 3 * window)
                                           : length / static_cast<double>(stops[k].sweeps.size()));
    }
  }
  // What the trace costs, before any of it is made: its duration (the moves at their longest
  // without a schedule) times the rate.
  double duration_s = timed ? end_at[K - 1] : o.first_extra_s + o.last_extra_s;
  if (!timed) {
    for (std::size_t k = 0; k < K; ++k)
      duration_s +=
          o.dwell_s * static_cast<double>(stops[k].sweeps.size()) + (k > 0 ? o.move_s_max : 0.0);
  }
  if (!(duration_s * o.rate_hz <= static_cast<double>(limits::kMaxTraceSamples))) {
    throw InputError("--trace-out", "",
                     "the trace would hold up to " + text::significant(duration_s * o.rate_hz, 3) +
                         " samples (" + text::significant(o.rate_hz, 6) + " Hz over " +
                         text::significant(duration_s, 6) + " s), more than the " +
                         std::to_string(limits::kMaxTraceSamples) +
                         " one trace may hold (docs/formats.md, \"Limits\"): lower the rate "
                         "(--trace-rate-hz) or the dwell (--trace-dwell-s)");
  }
  std::size_t r = 0;
  for (std::size_t k = 0; k < K; ++k) {
    const std::size_t parts = stops[k].sweeps.size();
    if (k > 0) {  // the move from the last level to this stop's first
      const double a = levels[r - 1], b = levels[r];
      const double T =
          timed ? move_T[k] : o.move_s_min + (o.move_s_max - o.move_s_min) * rng.uniform01();
      const double bump =
          o.excursion_um * (0.2 + 0.8 * rng.uniform01()) * (rng.uniform01() < 0.5 ? -1 : 1);
      const auto n = static_cast<long>(std::llround(T * o.rate_hz));
      for (long i = 0; i < n; ++i) {
        const double u = static_cast<double>(i) / static_cast<double>(n);
        const double step = 0.5 * (1 - std::cos(M_PI * u)), s = std::sin(M_PI * u);
        sample(a + (b - a) * step, bump * s * s + o.jitter_um * normal(rng));
      }
      settle = o.settle_um * (rng.uniform01() < 0.5 ? -1 : 1);
      settle_from = t;
    }
    // Without a move between them the bar does not change: the readings of one stop hold one
    // level, their mean.
    double level = 0;
    for (std::size_t q = 0; q < parts; ++q) level += levels[r + q] / static_cast<double>(parts);
    const double part = timed ? (end_at[k] - t) / static_cast<double>(parts) : o.dwell_s;
    for (std::size_t q = 0; q < parts; ++q, ++r) {
      double length = part;
      if (!timed && k == 0 && q == 0) length += o.first_extra_s;
      if (!timed && k + 1 == K && q + 1 == parts) length += o.last_extra_s;
      const double from = t;
      hold(level, length);
      out.level_um.push_back(level);
      out.dwell_s.emplace_back(from, t);
    }
  }
  return out;
}

std::optional<Warning> put_on_test_clock(const Design& design, std::vector<Reading>& readings,
                                         const std::map<std::string, double>& start_s,
                                         const std::string& source) {
  if (!start_s.empty()) {
    for (const Reading& r : readings) {
      if (!start_s.count(r.installation))
        throw InputError(source, r.installation,
                         "no start for this trace: give one for every trace, or none");
    }
    for (Reading& r : readings)
      if (r.time_s) *r.time_s += start_s.at(r.installation);
  }
  // A reading before zero (a trace whose clock began after its recording, or a start too early):
  // named by installation and angle; a start that puts it at >= 0 is what it needs.
  for (const Reading& r : readings) {
    if (!r.time_s || *r.time_s >= 0) continue;
    const std::string reading = "the reading at " + text::significant(r.angle_deg, 6) + " deg" +
                                (r.sweep ? std::string(" ") + sweep_name(*r.sweep) : "");
    if (!start_s.empty()) {
      throw InputError(source, r.installation,
                       "with this start " + reading + " falls at " +
                           text::significant(*r.time_s, 6) +
                           " s, before the test's clock began (times are >= 0)");
    }
    throw InputError(source, r.installation,
                     "on its trace's clock " + reading + " falls at " +
                         text::significant(*r.time_s, 6) +
                         " s, before zero (times are >= 0): give every trace's start on the "
                         "test's clock (a start at which its readings land at >= 0)");
  }
  if (readings_on_one_clock(design, readings)) return std::nullopt;
  if (!start_s.empty()) {
    throw InputError(source, "",
                     "with these starts the traces overlap in time (a ball bar measures one "
                     "installation at a time): each start is when its trace's clock read zero, "
                     "on the test's clock");
  }
  return Warning{"trace_clock",
                 "Each trace keeps its own clock: the readings' times restart with every "
                 "installation, so effects over the whole test (a drift or warm-up of the whole "
                 "test) cannot be formed from them. Give the start of every trace on the test's "
                 "clock (dbbkit readings --start ID=SECONDS) to put them on one clock."};
}

}  // namespace dbbkit
