// Raw traces in: the reader's dialects and refusals, the dwells found against the simulator's
// plateau levels over varied traces, the refusals and warnings when the trace does not fit the
// sweep, and the command line from simulate --trace-out through readings to identify.

#include "dbbkit/trace.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>
#include <nlohmann/json.hpp>
#include <random>
#include <sstream>

#include "cli_util.hpp"
#include "dbbkit/conformance.hpp"
#include "dbbkit/effects.hpp"
#include "dbbkit/error.hpp"
#include "dbbkit/identify.hpp"
#include "dbbkit/io/design_io.hpp"
#include "dbbkit/io/measurement_io.hpp"
#include "dbbkit/io/trace_io.hpp"
#include "dbbkit/uncertainty.hpp"
#include "test_util.hpp"

namespace dbbkit {
namespace {

Trace parse(const std::string& text, const io::TraceFormat& f = {}) {
  std::istringstream in(text);
  return io::parse_trace(in, f, "t.csv");
}

TEST(TraceReader, DelimitersDecimalCommaCommentsAndUnits) {
  Trace t = parse("\xEF\xBB\xBF# QC20 export\ntime_s,reading_um,extra\n0,1.5,x\n0.001,-2,y\n");
  ASSERT_EQ(t.time_s.size(), 2u);
  EXPECT_DOUBLE_EQ(t.reading_um[1], -2.0);
  t = parse("time_s;reading_mm\n0,000;0,0015\n0,001;-0,002\n");
  EXPECT_DOUBLE_EQ(t.time_s[1], 0.001);
  EXPECT_DOUBLE_EQ(t.reading_um[0], 1.5);  // mm to um, decimal comma
  t = parse("time_s\treading_um\n0\t1\n# a comment between samples\n\n1\t2\n");
  EXPECT_EQ(t.time_s.size(), 2u);
  t = parse("  time_s   reading_um\n 0   1.25\n 0.5  +2e-1\n");
  EXPECT_DOUBLE_EQ(t.reading_um[1], 0.2);
  // Another vendor's names and units, mapped; a sample index at a rate; the row's number.
  io::TraceFormat f;
  io::parse_trace_columns("time=Sample, reading=Deviation", f);
  f.unit = "mm";
  f.sample_rate_hz = 1000.0;
  t = parse("Sample;Deviation\n10;0,001\n11;0,002\n", f);
  EXPECT_DOUBLE_EQ(t.time_s[0], 0.01);
  EXPECT_DOUBLE_EQ(t.reading_um[1], 2.0);
  f = {};
  f.reading_column = "dev";
  f.unit = "um";
  f.sample_rate_hz = 500.0;
  t = parse("dev\n1\n2\n3\n", f);
  EXPECT_DOUBLE_EQ(t.time_s[2], 0.004);
}

TEST(TraceReader, RefusesWhatIsNotATrace) {
  for (const char* bad : {"", "# only a comment\n", "time_s,reading_um\n", "time,reading\n0,1\n",
                          "time_s,reading_um\n0,1\n0,2\n", "time_s,reading_um\n0,1\n1,nan\n",
                          "time_s,reading_um\n0,1\n1,1e400\n", "time_s,reading_um\n0,0x10\n",
                          "time_s,reading_um\n0,1,2\n", "time_s,reading_um,reading_mm\n0,1,2\n",
                          "time_s,reading_um\n0,1\n1,inf\n", "time_s,reading_um\n1,1\n0.5,1\n"}) {
    EXPECT_THROW(parse(bad), InputError) << bad;
  }
  io::TraceFormat f;
  EXPECT_THROW(io::parse_trace_columns("time", f), InputError);
  EXPECT_THROW(io::parse_trace_columns("speed=a", f), InputError);
  f.reading_column = "dev";  // without its unit
  EXPECT_THROW(parse("dev,time_s\n1,0\n", f), InputError);
  try {
    parse("time_s,reading_um\n0,1\n1,abc\n");
    ADD_FAILURE();
  } catch (const InputError& e) {
    EXPECT_EQ(e.where(), "line 3");
  }
}

// The detail of the InputError `f` throws ("" when it throws none).
template <class F>
std::string refusal(F&& f) {
  try {
    f();
  } catch (const InputError& e) {
    return e.where() + ": " + e.detail();
  }
  return "";
}

// A fresh directory under the system's temporary one (what was there removed), with `sub` in it.
std::filesystem::path fresh_dir(const std::string& name, const std::string& sub = "") {
  namespace fs = std::filesystem;
  const fs::path dir = fs::temp_directory_path() / (name + "_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(sub.empty() ? dir : dir / sub);
  return dir;
}

// The paper's C design simulated in `dir` (truth_c_per_angle.json, seed 4): sim.csv and a trace
// of each installation under `traces` (e.g. "tr/").
CliRun simulate_paper_traces(const std::filesystem::path& dir, const std::string& traces) {
  return run_cli_shell("cd " + dir.string() + " && " + DBBKIT_CLI + " simulate --design " +
                       test::source_path("designs/paper-c-turntable.json") + " --truth " +
                       test::source_path("tests/data/truth_c_per_angle.json") +
                       " --seed 4 --out sim.csv --trace-out " + traces);
}

// A simulated trace of `d`'s ccw sweep (the simulator's defaults), every stop at `level_um`.
SimulatedTrace level_trace(const Design& d, double level_um) {
  const std::vector<Stop> stops = program_stops(d, 0, {Sweep::kCCW});
  return simulate_trace(stops, std::vector<double>(stops.size(), level_um), {});
}

// A line is read to its bound, no further: a file without line ends (/dev/zero) is refused
// naming the line and the bound; a directory or a device is refused as what it is.
TEST(TraceReader, LinesAndFilesAreBounded) {
  std::string r = refusal([] { parse(std::string(1 << 20, '\0')); });
  EXPECT_NE(r.find("line 1: longer than"), std::string::npos) << r;
  r = refusal([] { parse("time_s,reading_um\n0,1\n" + std::string(1 << 20, '1') + "\n"); });
  EXPECT_NE(r.find("line 3: longer than"), std::string::npos) << r;
  const std::string dir = std::filesystem::temp_directory_path().string();
  r = refusal([&] { io::read_trace_file(dir, {}); });
  EXPECT_NE(r.find("a directory"), std::string::npos) << r;
  r = refusal([] { io::read_trace_file("/dev/zero", {}); });
  EXPECT_NE(r.find("not a regular file"), std::string::npos) << r;
}

// Old Mac line ends (CR alone) are line ends; CR LF and LF as before.
TEST(TraceReader, CarriageReturnLineEnds) {
  Trace t = parse("# cr\rtime_s,reading_um\r0,1\r0.001,2\r0.002,3");
  ASSERT_EQ(t.time_s.size(), 3u);
  EXPECT_DOUBLE_EQ(t.reading_um[2], 3.0);
  t = parse("time_s,reading_um\r\n0,1\r\n0.001,2\r\n");
  EXPECT_EQ(t.time_s.size(), 2u);
}

// A rate that makes the times absurd, a reading beyond a reading's limit, a unit that is none:
// each refused as what it is.
TEST(TraceReader, RatesReadingsAndUnitsOutOfRange) {
  io::TraceFormat f;
  f.sample_rate_hz = 5e-324;
  std::string r = refusal([&] { parse("time_s,reading_um\n0,1\n1,2\n", f); });
  EXPECT_NE(r.find("0.001"), std::string::npos) << r;
  r = refusal([] { parse("time_s,reading_mm\n0,1\n1,1e306\n"); });
  EXPECT_NE(r.find("line 3"), std::string::npos) << r;
  EXPECT_NE(r.find("beyond"), std::string::npos) << r;
  f = {};
  f.unit = "furlong";
  r = refusal([&] { parse("time_s,reading_um\n0,1\n1,2\n", f); });
  EXPECT_NE(r.find("furlong"), std::string::npos) << r;
  // The same reading from arrays.
  Trace t;
  for (int i = 0; i < 100; ++i) {
    t.time_s.push_back(i * 0.01);
    t.reading_um.push_back(i == 50 ? 1e306 : 0.0);
  }
  r = refusal([&] { find_plateaus(t, DwellOptions{}, "t"); });
  EXPECT_NE(r.find("sample 51"), std::string::npos) << r;
  EXPECT_NE(r.find("beyond"), std::string::npos) << r;
}

// Readings whose level lies within their Type A interval (u_a_um at 95 %, Student's t at
// u_a_dof), of those that have one.
struct TypeACount {
  int covered = 0, total = 0;
};

// A trace of `stops` at random levels, simulated with `o`; the readings found against the levels
// (with the drift the simulator adds on its clock at each reading's time).
double worst_error(const Design& d, const std::vector<Sweep>& sweeps, const TraceSimulation& o,
                   std::uint64_t seed, DwellOptions dwell = {}, TypeACount* type_a = nullptr) {
  const std::vector<Stop> stops = program_stops(d, 0, sweeps);
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> level(-50, 50);
  std::vector<double> levels;
  for (const Stop& s : stops)
    for (std::size_t q = 0; q < s.sweeps.size(); ++q) levels.push_back(level(rng));
  const SimulatedTrace sim = simulate_trace(stops, levels, o);
  dwell.dwell_s = o.dwell_s;
  const TraceReadings r =
      readings_from_trace(d, d.installations[0].id, sim.trace, sweeps, dwell, "trace");
  EXPECT_EQ(r.readings.size(), levels.size());
  double worst = 0;
  for (std::size_t k = 0; k < r.readings.size() && k < levels.size(); ++k) {
    const double expected = sim.level_um[k] + o.drift_um_per_min * *r.readings[k].time_s / 60.0;
    worst = std::max(worst, std::abs(r.readings[k].reading_um - expected));
    if (type_a && r.readings[k].u_a_um) {
      const double U = coverage_factor(*r.readings[k].u_a_dof, 0.95) * *r.readings[k].u_a_um;
      type_a->covered += std::abs(r.readings[k].reading_um - expected) <= U;
      ++type_a->total;
    }
    // The reading's time lies within its dwell.
    EXPECT_GE(*r.readings[k].time_s, sim.dwell_s[k].first);
    EXPECT_LE(*r.readings[k].time_s, sim.dwell_s[k].second);
    EXPECT_GT(*r.readings[k].samples, 0.2 * o.rate_hz * o.dwell_s);  // a fifth of the dwell
  }
  return worst;
}

// Every parameter of the simulator varied: the readings come back within 0.05 um at 0.15 um
// sample noise and 2 s dwells.
TEST(TraceDwells, RecoverTheSimulatorsLevelsOverVariedTraces) {
  const Design d = test::paper_design('C');
  int cases = 0;
  TypeACount type_a;
  for (int v = 0; v < 8; ++v) {
    TraceSimulation o;
    o.seed = 100 + static_cast<std::uint64_t>(v);
    o.rate_hz = v % 3 == 0 ? 1000 : v % 3 == 1 ? 500 : 2000;
    o.excursion_um = 5 + 10 * v;
    o.move_s_min = 0.6 + 0.2 * (v % 3);
    o.move_s_max = o.move_s_min + 0.5 * v;
    o.settle_um = (v % 4) * 2.0;
    o.settle_tau_s = 0.05 + 0.03 * (v % 3);
    o.jitter_um = 0.1 * v;
    o.resolution_um = v % 2 ? 0.1 : 0.01;
    o.drift_um_per_min = v % 3 == 2 ? 0.4 : 0.0;
    o.first_extra_s = 0.2 + v;
    o.last_extra_s = 4.0 - 0.4 * v;
    const std::vector<Sweep> sweeps =
        v % 2 ? std::vector<Sweep>{Sweep::kCCW, Sweep::kCW} : std::vector<Sweep>{Sweep::kCW};
    const double worst = worst_error(d, sweeps, o, 7 + v, {}, &type_a);
    EXPECT_LT(worst, 0.05) << "case " << v;
    std::printf("trace case %d: worst |reading - level| %.4f um\n", v, worst);
    ++cases;
  }
  EXPECT_EQ(cases, 8);
  // Each reading's Type A (batch means) covers its level at about the stated 95 %.
  EXPECT_GT(type_a.total, 150);
  const double share = static_cast<double>(type_a.covered) / type_a.total;
  std::printf("Type A of the readings: %d of %d levels within U (95 %%)\n", type_a.covered,
              type_a.total);
  EXPECT_GT(share, 0.90);
  EXPECT_LT(share, 0.99);
}

TEST(TraceDwells, TooManyOrTooFewDwellsNameTheInstallationAndBothCounts) {
  const Design d = test::paper_design('C');
  TraceSimulation o;
  const std::vector<Stop> stops = program_stops(d, 0, {Sweep::kCCW, Sweep::kCW});
  ASSERT_EQ(stops.size(), 2 * d.angles_deg.size() - 1);  // the turn: one stop, two readings
  const SimulatedTrace sim =
      simulate_trace(stops, std::vector<double>(2 * d.angles_deg.size(), 1.0), o);
  DwellOptions dwell;
  // Read as one sweep: more dwells than stops.
  try {
    readings_from_trace(d, "1r", sim.trace, {Sweep::kCCW}, dwell, "1r.csv");
    ADD_FAILURE();
  } catch (const InputError& e) {
    const std::string w = e.what();
    EXPECT_NE(w.find("installation 1r"), std::string::npos) << w;
    EXPECT_NE(w.find("found " + std::to_string(stops.size()) + " dwells"), std::string::npos) << w;
    EXPECT_NE(w.find(std::to_string(d.angles_deg.size()) + " stops"), std::string::npos) << w;
  }
  // A dwell of 5 s declared: none of the 2 s dwells is long enough.
  dwell.dwell_s = 5;
  EXPECT_THROW(readings_from_trace(d, "1r", sim.trace, {Sweep::kCCW, Sweep::kCW}, dwell, "1r.csv"),
               InputError);
  EXPECT_THROW(readings_from_trace(d, "9z", sim.trace, {Sweep::kCCW}, DwellOptions{}, "9z.csv"),
               InputError);
}

// The fastest drift the dwell finder reliably takes for still (max_still_drift_um_per_min: a
// quarter of its tolerance of neighbouring windows' means): traces drifting at 0.9 of it, up and
// down, are read stop for stop on twenty seeds; at five times it dwells are lost, and the refusal
// states the drift the finder takes at the noise it found.
TEST(TraceDwells, ADriftTheFinderTakesForStillIsTheOneItStates) {
  const Design d = test::paper_design('C');
  TraceSimulation o;  // 0.15 um at 1 kHz
  const double still = max_still_drift_um_per_min(o.noise_um, 1.0 / o.rate_hz);
  // By hand: windows of 0.1 s, 100 samples; a quarter of 6 standard errors 0.15 sqrt(2 / 100) um.
  EXPECT_NEAR(still, 0.25 * 6 * 0.15 * std::sqrt(2.0 / 100) / 0.1 * 60, 1e-9);
  // Each stop read, at the level plus the drift at the reading's time. (A drift shortens the
  // settled part of each dwell, the part within the noise of its final level, so a reading may
  // average the dwell's end alone: the cost is its Type A, not the reading.)
  const std::vector<Stop> stops = program_stops(d, 0, {Sweep::kCCW});
  for (std::uint64_t seed = 1; seed <= 20; ++seed) {
    o.seed = seed;
    o.drift_um_per_min = (seed % 2 ? 0.9 : -0.9) * still;
    std::vector<double> levels;
    for (std::size_t k = 0; k < stops.size(); ++k) levels.push_back(10 * std::sin(0.3 * k + seed));
    const SimulatedTrace sim = simulate_trace(stops, levels, o);
    DwellOptions dwell;
    dwell.dwell_s = o.dwell_s;
    const TraceReadings r = readings_from_trace(d, "1r", sim.trace, {Sweep::kCCW}, dwell, "1r.csv");
    ASSERT_EQ(r.readings.size(), levels.size()) << seed;
    for (std::size_t k = 0; k < levels.size(); ++k)
      EXPECT_NEAR(r.readings[k].reading_um,
                  sim.level_um[k] + o.drift_um_per_min * *r.readings[k].time_s / 60.0, 1.0)
          << seed << " " << k;
  }
  o.drift_um_per_min = 5 * still;
  const SimulatedTrace sim = simulate_trace(stops, std::vector<double>(stops.size(), 1.0), o);
  const std::string r = refusal(
      [&] { readings_from_trace(d, "1r", sim.trace, {Sweep::kCCW}, DwellOptions{}, "1r.csv"); });
  // The drift it states is the one it takes at the noise it found (the drift widens a window's
  // scatter a little, and with it the noise found).
  const std::string said = "drifts by less than about ";
  ASSERT_NE(r.find(said), std::string::npos) << r;
  const double stated = std::stod(r.substr(r.find(said) + said.size()));
  const std::string noise = "at the sample noise found, ";
  ASSERT_NE(r.find(noise), std::string::npos) << r;
  const double found = std::stod(r.substr(r.find(noise) + noise.size()));
  EXPECT_NEAR(stated, max_still_drift_um_per_min(found, 1.0 / o.rate_hz), 0.05 * stated) << r;
  EXPECT_GE(stated, 0.9 * still) << r;
  // Below the stillness test's noise floor the floor is what it uses, and what it says.
  EXPECT_EQ(stillness_noise_um(1e-9), stillness_noise_um(0.005));
  EXPECT_EQ(max_still_drift_um_per_min(1e-9, 1e-3), max_still_drift_um_per_min(0.005, 1e-3));
}

// Times are written to the microsecond: a trace at 50 kHz (20 us apart) reads back with every
// sample's time (at 0.1 ms its times repeated, and the reader refused the trace).
TEST(TraceDwells, AFastTracesTimesAreWrittenToTheMicrosecond) {
  Trace t;
  for (int i = 0; i < 1000; ++i) {
    t.time_s.push_back(i * 2e-5);
    t.reading_um.push_back(0.5 * std::sin(0.01 * i));
  }
  std::stringstream text;
  io::write_trace_csv(text, t, {});
  const Trace back = io::parse_trace(text, io::TraceFormat{}, "fast.csv");
  ASSERT_EQ(back.time_s.size(), t.time_s.size());
  for (std::size_t i = 0; i < t.time_s.size(); ++i)
    EXPECT_NEAR(back.time_s[i], t.time_s[i], 5e-7) << i;
}

// A recording started during the first move, with a return home and a dwell there at the end:
// as many dwells as stops, each a stop later than its angle. Refused, naming the likely cause.
TEST(TraceDwells, RecordingStartedDuringAMoveIsRefused) {
  const Design d = test::paper_design('C');
  std::vector<Stop> stops = program_stops(d, 0, {Sweep::kCCW});
  stops.push_back({0.0, {Sweep::kCCW}});  // home
  std::vector<double> levels;
  for (std::size_t k = 0; k < stops.size(); ++k) levels.push_back(std::sin(0.7 * k) * 5);
  const SimulatedTrace sim = simulate_trace(stops, levels, TraceSimulation{});
  Trace t;
  const double from = sim.dwell_s[0].second + 0.5;  // moves take 1 to 3 s
  for (std::size_t i = 0; i < sim.trace.time_s.size(); ++i) {
    if (sim.trace.time_s[i] < from) continue;
    t.time_s.push_back(sim.trace.time_s[i] - from);
    t.reading_um.push_back(sim.trace.reading_um[i]);
  }
  const std::string r =
      refusal([&] { readings_from_trace(d, "1r", t, {Sweep::kCCW}, DwellOptions{}, "1r.csv"); });
  EXPECT_NE(r.find("installation 1r"), std::string::npos) << r;
  EXPECT_NE(r.find("started during a move"), std::string::npos) << r;
  EXPECT_NE(r.find("return home"), std::string::npos) << r;
}

// A clock that jumps by 11.6 days between two samples, and times in milliseconds since 1970:
// refused, naming the sample and the jump, or the unit.
TEST(TraceDwells, ClockJumpsAndEpochMillisecondsAreRefused) {
  const Design d = test::paper_design('C');
  const std::vector<Stop> stops = program_stops(d, 0, {Sweep::kCCW});
  SimulatedTrace sim = simulate_trace(stops, std::vector<double>(stops.size(), 1.0), {});
  Trace t = sim.trace;
  const std::size_t at = t.time_s.size() / 2;
  for (std::size_t i = at; i < t.time_s.size(); ++i) t.time_s[i] += 1e6;
  std::string r = refusal([&] { find_plateaus(t, DwellOptions{}, "1r.csv"); });
  EXPECT_NE(r.find("sample " + std::to_string(at + 1)), std::string::npos) << r;
  EXPECT_NE(r.find("jumps"), std::string::npos) << r;
  t = sim.trace;
  for (std::size_t i = 0; i < t.time_s.size(); ++i) t.time_s[i] = 1.7e12 + static_cast<double>(i);
  r = refusal([&] { find_plateaus(t, DwellOptions{}, "1r.csv"); });
  EXPECT_NE(r.find("milliseconds since 1970"), std::string::npos) << r;
}

// A pause in the middle of a sweep and a dwell where the machine did not stand still: the
// readings are taken, and the abnormal dwells named in warnings.
TEST(TraceDwells, AbnormalDwellsAreNamed) {
  const Design d = test::paper_design('C');
  const std::vector<Stop> stops = program_stops(d, 0, {Sweep::kCCW});
  TraceSimulation o;
  SimulatedTrace sim = simulate_trace(stops, std::vector<double>(stops.size(), 0.0), o);
  // Stretch dwell 5 to 8 s (a pause) by inserting still samples; add noise to dwell 9.
  Trace t;
  std::mt19937_64 rng(5);
  std::normal_distribution<double> normal(0.0, 1.0);
  const double dt = 1.0 / o.rate_hz;
  double shift = 0;
  for (std::size_t i = 0; i < sim.trace.time_s.size(); ++i) {
    const double time = sim.trace.time_s[i];
    double x = sim.trace.reading_um[i];
    if (time >= sim.dwell_s[9].first + 0.5 && time < sim.dwell_s[9].second)
      x += 0.18 * normal(rng);  // noisier than the trace: still by the test, but not quiet
    t.time_s.push_back(time + shift);
    t.reading_um.push_back(x);
    if (std::abs(time - 0.5 * (sim.dwell_s[5].first + sim.dwell_s[5].second)) < dt / 2) {
      for (int k = 0; k < 6000; ++k) {
        shift += dt;
        t.time_s.push_back(time + shift);
        t.reading_um.push_back(x);
      }
    }
  }
  const TraceReadings r = readings_from_trace(d, "1r", t, {Sweep::kCCW}, DwellOptions{}, "1r.csv");
  std::string kinds;
  for (const Warning& w : r.warnings) kinds += w.kind + " (" + w.text + ")\n";
  EXPECT_NE(kinds.find("trace_length (installation 1r, dwell 6"), std::string::npos) << kinds;
  EXPECT_NE(kinds.find("trace_scatter (installation 1r, dwell 10"), std::string::npos) << kinds;
}

// Samples closer than a microsecond (a time column in the wrong unit) and a trace too short
// for four windows are refused; a 50 Hz trace (windows of 20 samples, 0.4 s) is read right.
TEST(TraceDwells, RatesAtTheEdges) {
  const Design d = test::paper_design('C');
  Trace tiny;
  for (int i = 0; i < 40; ++i) {
    tiny.time_s.push_back(i * 1e-25);
    tiny.reading_um.push_back(1.0);
  }
  EXPECT_THROW(find_plateaus(tiny, DwellOptions{}, "t"), InputError);
  for (double& t : tiny.time_s) t *= 1e22;  // 40 samples 0.1 ms apart: fewer than four windows
  EXPECT_THROW(find_plateaus(tiny, DwellOptions{}, "t"), InputError);
  // At 50 Hz the windows are 0.4 s: a dwell may be lost to its settling, and then the count
  // refuses the trace; what is read is never shifted to another angle.
  int read = 0, refused = 0;
  for (std::uint64_t seed = 1; seed <= 6; ++seed) {
    TraceSimulation o;
    o.rate_hz = 50;
    o.seed = seed;
    try {
      EXPECT_LT(worst_error(d, {Sweep::kCCW}, o, seed), 0.1) << "seed " << seed;
      ++read;
    } catch (const InputError&) {
      ++refused;
    }
  }
  EXPECT_GT(read, 0);
  std::printf("50 Hz traces: %d read, %d refused\n", read, refused);
}

TEST(TraceMeasurementFile, ScatterAndSamplesColumns) {
  std::vector<Reading> r = io::parse_measurements(
      "installation,angle_deg,reading_um,std_um,samples\n1r,0,1.5,0.15,1800\n", "m.csv");
  ASSERT_EQ(r.size(), 1u);
  EXPECT_DOUBLE_EQ(*r[0].std_um, 0.15);
  EXPECT_EQ(*r[0].samples, 1800);
  std::ostringstream out;
  io::write_measurements_csv(out, r);
  EXPECT_EQ(out.str(),
            "installation,angle_deg,reading_um,std_um,samples\n1r,0,1.500000,0.150000,1800\n");
  EXPECT_THROW(io::parse_measurements("installation,angle_deg,reading_um,std_um\n1r,0,1,-1\n", "m"),
               InputError);
  EXPECT_THROW(io::parse_measurements("installation,angle_deg,reading_um,samples\n1r,0,1,0\n", "m"),
               InputError);
  // The Type A columns: read, written back, the two together.
  r = io::parse_measurements(
      "installation,angle_deg,reading_um,u_a_um,u_a_dof\n1r,0,1.5,0.004,14\n", "m.csv");
  EXPECT_DOUBLE_EQ(*r[0].u_a_um, 0.004);
  EXPECT_EQ(*r[0].u_a_dof, 14);
  out.str("");
  io::write_measurements_csv(out, r);
  EXPECT_EQ(out.str(),
            "installation,angle_deg,reading_um,u_a_um,u_a_dof\n1r,0,1.500000,0.004000,14\n");
  EXPECT_THROW(
      io::parse_measurements("installation,angle_deg,reading_um,u_a_um\n1r,0,1,0.1\n", "m"),
      InputError);
  EXPECT_THROW(io::parse_measurements(
                   "installation,angle_deg,reading_um,u_a_um,u_a_dof\n1r,0,1,0.1,0\n", "m"),
               InputError);
}

// identify --type-a-readings: each reading's Type A beside the declared noise, by hand. With
// every reading at u_a = a (dof nu) the weights scale alike, so every u_c is the declared-only
// one times sqrt(sigma^2 + a^2) / sigma, its repeatability component that times a / sigma, and
// the component's Welch-Satterthwaite dof nu (sum g^2)^2 / sum g^4 >= nu.
TEST(TraceTypeA, ReadingsTypeAEntersTheBudget) {
  const Design d = test::paper_design('C');
  std::vector<Reading> readings =
      io::read_measurement_file(test::source_path("tests/data/paper/paper_c_turntable.csv"), d);
  const IdentifyResult plain = identify(d, readings);
  const double a = 0.5, sigma = d.noise.sigma_um();
  for (Reading& r : readings) r.u_a_um = a, r.u_a_dof = 10;
  IdentifyOptions o;
  o.budget = with_reading_type_a(o.budget, readings, "test", "--type-a-readings");
  const IdentifyResult r = identify(d, readings, o);
  ASSERT_EQ(r.budget.values.size(), plain.budget.values.size());
  EXPECT_TRUE(r.budget.reading_type_a);
  for (std::size_t i = 0; i < r.budget.values.size(); ++i) {
    const ValueBudget &v = r.budget.values[i], &p = plain.budget.values[i];
    EXPECT_NEAR(v.value, p.value, 1e-9);
    EXPECT_NEAR(v.u_c, p.u_c * std::sqrt(sigma * sigma + a * a) / sigma, 1e-9 * (1 + p.u_c));
    ASSERT_EQ(v.components.size(), 2u);
    EXPECT_EQ(v.components[0].name, "reading noise");
    EXPECT_NEAR(v.components[0].u, p.u_c, 1e-9 * (1 + p.u_c));
    EXPECT_EQ(v.components[1].name, "reading repeatability");
    EXPECT_EQ(v.components[1].type, "A");
    EXPECT_NEAR(v.components[1].u, p.u_c * a / sigma, 1e-9 * (1 + p.u_c));
    ASSERT_TRUE(v.components[1].dof);
    EXPECT_GE(*v.components[1].dof, 10 - 1e-9);
    ASSERT_TRUE(v.nu_eff);
    EXPECT_GT(v.k, 1.959963);  // Student's t at a finite nu_eff
  }
  // The ISO 230 quantities pool the same readings: their t (the error motions' Monte Carlo, the
  // tolerance decisions' k) takes the least effective degrees of freedom of the errors.
  double least = std::numeric_limits<double>::infinity();
  for (const ValueBudget& v : r.budget.values) least = std::min(least, *v.nu_eff);
  EXPECT_GE(least, 10 - 1e-9);
  ASSERT_TRUE(iso_degrees_of_freedom(r.budget));
  EXPECT_EQ(*iso_degrees_of_freedom(r.budget), least);
  EXPECT_FALSE(iso_degrees_of_freedom(plain.budget));
  ASSERT_FALSE(r.iso.motion_values.values.empty());
  EXPECT_EQ(r.iso.motion_values.dof, least);
  Tolerance x0c;
  x0c.quantity = "X0C";
  x0c.lower = -100;
  x0c.upper = 100;
  x0c.where = "limits[0]";
  const ConformanceReport rep = decide_conformance(d, r, {x0c}, "test");
  EXPECT_EQ(rep.type_a_dof, least);
  EXPECT_NEAR(rep.k_iso, coverage_factor(least, 0.95), 1e-12);
  EXPECT_GT(rep.k_iso, 1.96);
  const Determined& iso_x = r.iso.location[0].value;
  ASSERT_TRUE(rep.results[0].high);
  EXPECT_NEAR(*rep.results[0].high - iso_x.value, rep.k_iso * iso_x.std, 1e-9 * (1 + iso_x.std));
  // A reading without its Type A is named; --type-a with it is refused.
  readings[3].u_a_um.reset();
  readings[3].u_a_dof.reset();
  EXPECT_THROW(with_reading_type_a(BudgetOptions{}, readings, "test", "--type-a-readings"),
               InputError);
  BudgetOptions both;
  both.type_a = true;
  EXPECT_THROW(with_reading_type_a(both, readings, "test", "--type-a-readings"), InputError);
}

// simulate --trace-out writes a trace per installation; readings turns them back into the
// readings simulate wrote (within 0.05 um); identify reads them.
TEST(TraceCommandLine, FromSimulatedTracesToIdentify) {
  namespace fs = std::filesystem;
  const fs::path dir = fresh_dir("dbbkit_trace", "traces");
  const std::string D = test::source_path("designs/paper-c-turntable.json");
  const std::string cd = "cd " + dir.string() + " && " + DBBKIT_CLI + " ";
  CliRun r = simulate_paper_traces(dir, "traces/");
  ASSERT_EQ(r.status, 0) << r.err;
  std::string cmd = "readings --design " + D + " --out m.csv";
  for (const char* id : {"1r", "1t", "1a", "2r", "2t", "2a", "3r", "3t", "3a"}) {
    if (fs::exists(dir / "traces" / (std::string(id) + ".csv")))
      cmd += std::string(" --trace ") + id + "=traces/" + id + ".csv";
  }
  r = run_cli_shell(cd + cmd);
  ASSERT_EQ(r.status, 0) << r.err;
  const Design d = test::paper_design('C');
  const std::vector<Reading> sim = io::read_measurement_file((dir / "sim.csv").string(), d);
  const std::vector<Reading> got = io::read_measurement_file((dir / "m.csv").string(), d);
  ASSERT_EQ(got.size(), sim.size());
  for (const Reading& g : got) {
    bool matched = false;
    for (const Reading& s : sim) {
      if (s.installation == g.installation && s.angle_deg == g.angle_deg) {
        EXPECT_NEAR(g.reading_um, s.reading_um, 0.05) << g.installation << " " << g.angle_deg;
        matched = true;
      }
    }
    EXPECT_TRUE(matched);
    EXPECT_TRUE(g.std_um && g.samples && g.time_s);
  }
  r = run_cli_shell(cd + "identify --design " + D + " --data m.csv --out id.json --quiet");
  EXPECT_EQ(r.status, 0) << r.err;
  // Each reading's Type A: a budget component; refused on readings without it and with Monte
  // Carlo (which draws the declared noise only).
  r = run_cli_shell(cd + "identify --design " + D + " --data m.csv --type-a-readings --out -");
  ASSERT_EQ(r.status, 0) << r.err;
  const nlohmann::json j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["budget"]["values"][0]["components"][1]["name"], "reading repeatability");
  EXPECT_NE(j["budget"]["noise_evaluation"].get<std::string>().find("repeatability"),
            std::string::npos);
  r = run_cli_shell(cd + "identify --design " + D + " --data sim.csv --type-a-readings --out -");
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.err.find("has no u_a_um"), std::string::npos) << r.err;
  r = run_cli_shell(cd + "identify --design " + D +
                    " --data m.csv --type-a-readings --monte-carlo --out -");
  EXPECT_EQ(r.status, 2);
  // A trace of another dwell: refused with both counts, exit 2, nothing written.
  r = run_cli_shell(cd + "readings --design " + D +
                    " --trace 1r=traces/1r.csv --dwell-s 6 --out x.csv");
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.err.find("installation 1r"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(dir / "x.csv"));
  fs::remove_all(dir);
}

// The test's clock: a drift of the whole test (0.3 um/min, the truth's schedule) hidden in the
// traces. Each trace's clock starts at zero: without --start the readings' times overlap, the
// terminal says so and diagnose cannot form the whole test's drift; with the starts the
// simulator wrote in each trace's comments, diagnose finds it. Starts for some traces only, for
// an installation without a trace, or making two traces overlap are refused (exit 2).
TEST(TraceCommandLine, TracesOnTheTestsClock) {
  namespace fs = std::filesystem;
  const fs::path dir =
      fs::temp_directory_path() / ("dbbkit_trace_clock_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir / "tr");
  const std::string D = test::source_path("tests/data/c_fourier2_bar150.json");
  {
    std::ifstream in(test::source_path("tests/data/truth_whole_test.json"));
    nlohmann::json t = nlohmann::json::parse(in);
    t["schedule"]["sweeps"] = {"ccw", "cw"};
    std::ofstream(dir / "truth.json") << t.dump();
  }
  const std::string cd = "cd " + dir.string() + " && " + DBBKIT_CLI + " ";
  // 250 Hz (the windows' 20 samples in 0.1 s): a fourth of the samples of 1 kHz, the same dwells.
  CliRun r = run_cli_shell(cd + "simulate --design " + D +
                           " --truth truth.json --out sim.csv --trace-out tr/ --trace-rate-hz 250");
  ASSERT_EQ(r.status, 0) << r.err;
  const Design d = io::read_design_file(D);
  // Each trace's comments give its start on the test's clock and the dwell the schedule left.
  std::string traces, starts;
  double dwell = 1e9;
  for (const Installation& in : d.installations) {
    traces += " --trace " + in.id + "=tr/" + in.id + ".csv";
    std::ifstream f(dir / "tr" / (in.id + ".csv"));
    std::string line, start;
    while (std::getline(f, line) && line.rfind('#', 0) == 0) {
      const std::size_t at = line.find("--start " + in.id + "=");
      if (at != std::string::npos) start = line.substr(at + 8);
      const std::size_t dw = line.find("--dwell-s ");
      if (dw != std::string::npos) dwell = std::min(dwell, std::stod(line.substr(dw + 10)));
    }
    ASSERT_FALSE(start.empty()) << in.id;
    starts += " --start " + start;
  }
  ASSERT_GT(dwell, 5.0);  // the schedule's 10 s a reading less a move of up to 3 s
  ASSERT_LT(dwell, 9.0);
  const std::string readings =
      cd + "readings --design " + D + " --sweeps both --dwell-s " + std::to_string(dwell) + traces;
  r = run_cli_shell(readings + " --out own.csv");
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_NE(r.err.find("Each trace keeps its own clock"), std::string::npos) << r.err;
  r = run_cli_shell(readings + starts + " --out test.csv");
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_EQ(r.err.find("own clock"), std::string::npos) << r.err;
  EXPECT_EQ(r.err.find("a pause"), std::string::npos) << r.err;  // the dwells as the comments say
  const std::vector<Reading> own = io::read_measurement_file((dir / "own.csv").string(), d);
  const std::vector<Reading> on_test = io::read_measurement_file((dir / "test.csv").string(), d);
  EXPECT_FALSE(readings_on_one_clock(d, own));
  EXPECT_TRUE(readings_on_one_clock(d, on_test));
  // The readings' times follow the schedule's (the simulator's readings): the median within
  // half a second, each within 5 s (a turn's two readings, 10 s apart in the schedule, split one
  // plateau in halves).
  const std::vector<Reading> sim = io::read_measurement_file((dir / "sim.csv").string(), d);
  ASSERT_EQ(sim.size(), on_test.size());
  std::vector<double> lag;
  for (const Reading& g : on_test) {
    for (const Reading& s : sim) {
      if (s.installation == g.installation && s.angle_deg == g.angle_deg && s.sweep == g.sweep)
        lag.push_back(std::abs(*g.time_s - *s.time_s));
    }
  }
  ASSERT_EQ(lag.size(), sim.size());
  std::sort(lag.begin(), lag.end());
  EXPECT_LT(lag[lag.size() / 2], 0.5);
  EXPECT_LT(lag.back(), 5.0);
  auto added = [&](const std::string& data) {
    const CliRun g =
        run_cli_shell(cd + "diagnose --design " + D + " --data " + data + " --out - --quiet");
    EXPECT_EQ(g.status, 0) << g.err;
    return nlohmann::json::parse(g.out);
  };
  const nlohmann::json a = added("own.csv");
  for (const auto& e : a["added_effects"]) EXPECT_NE(e["label"], "drift[all]");
  bool not_applicable = false;
  for (const auto& c : a["candidates"]) {
    if (c["label"] == "drift[all]")
      not_applicable = c["detail"].get<std::string>().find("one clock") != std::string::npos;
  }
  EXPECT_TRUE(not_applicable) << a["candidates"].dump();
  const nlohmann::json b = added("test.csv");
  bool found = false;
  for (const auto& e : b["added_effects"]) {
    if (e["label"] != "drift[all]") continue;
    found = true;
    EXPECT_NEAR(e["value"]["value"].get<double>(), 0.3, 3 * e["std"]["value"].get<double>());
  }
  EXPECT_TRUE(found) << b["added_effects"].dump();
  // Refusals.
  const std::string one = readings + " --out x.csv --start 1r=0";
  r = run_cli_shell(one);
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.err.find("give one for every trace"), std::string::npos) << r.err;
  r = run_cli_shell(readings + starts + " --start 9z=3 --out x.csv");
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.err.find("no --trace of this installation"), std::string::npos) << r.err;
  std::string zeros;
  for (const Installation& in : d.installations) zeros += " --start " + in.id + "=0";
  r = run_cli_shell(readings + zeros + " --out x.csv");
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.err.find("overlap in time"), std::string::npos) << r.err;
  r = run_cli_shell(readings + starts + " --start 1r=-100 --out x.csv");
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.err.find("given twice"), std::string::npos) << r.err;
  r = run_cli_shell(readings + starts.substr(0, starts.find(" --start 1t")) + "0x10" +
                    starts.substr(starts.find(" --start 1t")) + " --out x.csv");
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.err.find("expected a number of seconds"), std::string::npos) << r.err;
  r = run_cli_shell(readings + " --start 1r=-100" + starts.substr(starts.find(" --start 1t")) +
                    " --out x.csv");
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.err.find("before the test's clock began"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(dir / "x.csv"));
  // A schedule too fast for the dwell and the moves: refused, naming it, nothing written.
  {
    std::ifstream in(dir / "truth.json");
    nlohmann::json t = nlohmann::json::parse(in);
    t["schedule"]["per_reading_s"] = 3;
    std::ofstream(dir / "fast.json") << t.dump();
  }
  r = run_cli_shell(cd + "simulate --design " + D +
                    " --truth fast.json --out y.csv --trace-out tr/fast_");
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.err.find("per_reading_s"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(dir / "y.csv"));
  fs::remove_all(dir);
}

// Each committed truth with a schedule (ccw, cw, ccw) gives traces that the advice in their
// comments reads, one by one and all together on the test's clock (seed 2: 1r's first plateau,
// cut where the test's clock begins, is shorter than half the inner dwells).
TEST(TraceCommandLine, SimulatedTracesReadAsTheirCommentsSay) {
  namespace fs = std::filesystem;
  const fs::path dir =
      fs::temp_directory_path() / ("dbbkit_trace_advice_" + std::to_string(::getpid()));
  const std::string D = test::source_path("tests/data/c_fourier2_bar150.json");
  const Design d = io::read_design_file(D);
  for (const char* truth :
       {"truth_whole_test.json", "truth_drift_example.json", "truth_step.json"}) {
    fs::remove_all(dir);
    fs::create_directories(dir / "tr");
    const std::string cd = "cd " + dir.string() + " && " + DBBKIT_CLI + " ";
    CliRun r = run_cli_shell(cd + "simulate --design " + D + " --truth " +
                             test::source_path(std::string("tests/data/") + truth) +
                             " --seed 2 --out sim.csv --trace-out tr/ --trace-rate-hz 250");
    ASSERT_EQ(r.status, 0) << truth << "\n" << r.err;
    std::string all, sweeps;
    double dwell = 1e9;  // one for all: the least
    for (const Installation& in : d.installations) {
      std::ifstream f(dir / "tr" / (in.id + ".csv"));
      std::string line, advice;
      while (std::getline(f, line) && line.rfind('#', 0) == 0) {
        const std::size_t at = line.find("dbbkit readings ");
        if (at != std::string::npos) advice = line.substr(at + 16);
      }
      ASSERT_FALSE(advice.empty()) << truth << " " << in.id;
      EXPECT_NE(advice.find("--sweeps ccw,cw,ccw"), std::string::npos) << advice;
      const std::string trace = " --trace " + in.id + "=tr/" + in.id + ".csv ";
      r = run_cli_shell(cd + "readings --design " + D + trace + advice + " --out -");
      EXPECT_EQ(r.status, 0) << truth << " " << in.id << ": " << advice << "\n" << r.err;
      all += trace + advice.substr(advice.find("--start"));
      dwell = std::min(dwell, std::stod(advice.substr(advice.find("--dwell-s ") + 10)));
      sweeps = advice.substr(advice.find(" --sweeps"),
                             advice.find(" --start") - advice.find(" --sweeps"));
    }
    r = run_cli_shell(cd + "readings --design " + D + all + sweeps + " --dwell-s " +
                      std::to_string(dwell) + " --out m.csv");
    EXPECT_EQ(r.status, 0) << truth << "\n" << r.err;
    EXPECT_EQ(r.err.find("own clock"), std::string::npos) << r.err;
  }
  fs::remove_all(dir);
}

// A trace whose clock began after its recording (negative times) is put on the test's clock
// by a start at which its readings land at >= 0; without one, the refusal names the
// installation and the reading, not an index.
TEST(TraceCommandLine, NegativeTimesAndAStartThatMendsThem) {
  namespace fs = std::filesystem;
  const fs::path dir = fresh_dir("dbbkit_trace_negative");
  const Design d = test::paper_design('C');
  Trace t = level_trace(d, 1.0).trace;
  for (double& x : t.time_s) x -= 100;
  {
    std::ofstream out(dir / "1r.csv");
    io::write_trace_csv(out, t, {});
  }
  const std::string cd = "cd " + dir.string() + " && " + DBBKIT_CLI + " readings --design " +
                         test::source_path("designs/paper-c-turntable.json") +
                         " --trace 1r=1r.csv --out - ";
  CliRun r = run_cli_shell(cd);
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.err.find("1r"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("the reading at 0 deg"), std::string::npos) << r.err;
  EXPECT_EQ(r.err.find("reading 0"), std::string::npos) << r.err;
  r = run_cli_shell(cd + "--start 1r=100");
  EXPECT_EQ(r.status, 0) << r.err;
  r = run_cli_shell(cd + "--start 1r=-5");
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.err.find("with this start the reading at 0 deg"), std::string::npos) << r.err;
  fs::remove_all(dir);
}

// One file given for two installations, and a simulated trace that would be larger than a trace
// may be (100 kHz, 600 s dwells: about 1e9 samples): refused before anything is read or made.
TEST(TraceCommandLine, OneFileTwoInstallationsAndTracesTooLarge) {
  namespace fs = std::filesystem;
  const fs::path dir = fresh_dir("dbbkit_trace_bounds", "tr");
  const std::string D = test::source_path("designs/paper-c-turntable.json");
  const std::string cd = "cd " + dir.string() + " && ";
  CliRun r = simulate_paper_traces(dir, "tr/");
  ASSERT_EQ(r.status, 0) << r.err;
  r = run_cli_shell(cd + DBBKIT_CLI + " readings --design " + D +
                    " --trace 1r=tr/1r.csv --trace 1t=./tr/1r.csv --out -");
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.err.find("one file given for installations '1r' and '1t'"), std::string::npos)
      << r.err;
  // Refused before any of it is made (it would take about 18 GB a trace).
  r = run_cli_shell(cd + DBBKIT_CLI + " simulate --design " + D + " --truth " +
                    test::source_path("tests/data/truth_c_per_angle.json") +
                    " --seed 4 --out big.csv --trace-out big_ --trace-rate-hz 100000 "
                    "--trace-dwell-s 600");
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.err.find("--trace-rate-hz"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("50000000"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(dir / "big.csv"));
  EXPECT_FALSE(fs::exists(dir / "big_1r.csv"));
  // A drift the dwell finder would never take for still: refused before anything is written,
  // stating the drift it takes at the traces' noise and rate (a trace of 100 um/min was written,
  // and readings could not read it).
  r = run_cli_shell(cd + DBBKIT_CLI + " simulate --design " + D + " --truth " +
                    test::source_path("tests/data/truth_c_per_angle.json") +
                    " --seed 4 --out fast.csv --trace-out fast_ --trace-drift-um-per-min 100");
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.err.find("--trace-drift-um-per-min"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("a drift of at most 19.1 um/min"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(dir / "fast.csv"));
  EXPECT_FALSE(fs::exists(dir / "fast_1r.csv"));
  // Just within it, every installation's trace is read stop for stop.
  r = run_cli_shell(cd + DBBKIT_CLI + " simulate --design " + D + " --truth " +
                    test::source_path("tests/data/truth_c_per_angle.json") +
                    " --seed 4 --out slow.csv --trace-out slow_ --trace-drift-um-per-min 19");
  ASSERT_EQ(r.status, 0) << r.err;
  std::string traces;
  for (const Installation& in : io::read_design_file(D).installations)
    traces += " --trace " + in.id + "=slow_" + in.id + ".csv";
  r = run_cli_shell(cd + DBBKIT_CLI + " readings --design " + D + traces + " --out slow_m.csv");
  EXPECT_EQ(r.status, 0) << r.err;
  // A trace's option without --trace-out would change nothing written: refused, not dropped.
  for (const char* option : {"--trace-dwell-s 5", "--trace-rate-hz 500", "--trace-noise-um 0.1",
                             "--trace-excursion-um 10", "--trace-drift-um-per-min 1"}) {
    r = run_cli_shell(cd + DBBKIT_CLI + " simulate --design " + D + " --truth " +
                      test::source_path("tests/data/truth_c_per_angle.json") +
                      " --seed 4 --out lone.csv " + option);
    EXPECT_EQ(r.status, 2) << option;
    EXPECT_NE(r.err.find("--trace-out"), std::string::npos) << option << ": " << r.err;
    EXPECT_FALSE(fs::exists(dir / "lone.csv")) << option;
  }
  fs::remove_all(dir);
}

// What the caller got wrong is named as the caller's: an id that is no installation names
// --trace and lists the design's (it used to blame the file); a mm column of um readings names
// the line, the column and the unit (it said "reading 0 ... beyond range"); times in
// milliseconds from the start say so (they gave "found 145 dwells"); a rate given for a column
// of seconds is two clocks (it said "too short").
TEST(TraceCommandLine, WhatTheCallerGotWrongIsNamedAsTheCallers) {
  namespace fs = std::filesystem;
  const fs::path dir = fresh_dir("dbbkit_trace_named");
  const Design d = test::paper_design('C');
  const SimulatedTrace sim = level_trace(d, 5.0);
  std::ostringstream text;
  io::write_trace_csv(text, sim.trace, {"a comment"});
  std::string mm = text.str();
  mm.replace(mm.find("reading_um"), 10, "reading_mm");
  {
    std::ofstream(dir / "1r.csv") << text.str();
    std::ofstream(dir / "1r_mm.csv") << mm;
  }
  const std::string cd = "cd " + dir.string() + " && " + DBBKIT_CLI + " readings --design " +
                         test::source_path("designs/paper-c-turntable.json") + " --out - ";
  CliRun r = run_cli_shell(cd + "--trace 1R=1r.csv");
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.err.find("--trace: '1R': no installation of the design has this id (ids are "
                       "case-sensitive: '1r'?); its installations: 1r, 1t, 1a, 2r"),
            std::string::npos)
      << r.err;
  EXPECT_EQ(r.err.find("1r.csv"), std::string::npos) << r.err;
  r = run_cli_shell(cd + "--trace 1r=1r_mm.csv");
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.err.find("1r_mm.csv: line "), std::string::npos) << r.err;
  EXPECT_NE(r.err.find(", column 'reading_mm': installation 1r, dwell 1 at 0 deg"),
            std::string::npos)
      << r.err;
  EXPECT_NE(r.err.find(" mm is beyond the instrument's range of +-1 mm"), std::string::npos)
      << r.err;
  EXPECT_NE(r.err.find("are the readings in um? (a column reading_um, or --unit um)"),
            std::string::npos)
      << r.err;
  r = run_cli_shell(cd + "--trace 1r=1r.csv --sample-rate-hz 1000");
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.err.find("the column time_s holds seconds, and --sample-rate-hz would read it as a "
                       "sample index: one clock, not two"),
            std::string::npos)
      << r.err;
  fs::remove_all(dir);
  // Milliseconds from the start read as seconds.
  Trace ms = sim.trace;
  for (double& t : ms.time_s) t *= 1000;
  std::string m = refusal([&] { readings_from_trace(d, "1r", ms, {Sweep::kCCW}, {}, "1r.csv"); });
  EXPECT_NE(m.find("the times look like milliseconds (a sample every 1 ms is 1000 Hz)"),
            std::string::npos)
      << m;
  EXPECT_NE(m.find("longer than a dwell of 2 s (--dwell-s)"), std::string::npos) << m;
  // A sample index that is no whole number: seconds, with a rate.
  io::TraceFormat f;
  io::parse_trace_columns("time=t", f);
  f.sample_rate_hz = 1000;
  m = refusal([&] { parse("t,reading_um\n0,1\n0.001,2\n", f); });
  EXPECT_NE(m.find("line 3, column 't': '0.001' is no sample index (a whole number)"),
            std::string::npos)
      << m;
}

// One clock or several: an installation measured again at the end of the test is a run of its
// own on the test's clock; traces whose clocks restart at zero overlap.
TEST(TraceClock, RunsOfOneInstallationOnOneClock) {
  const Design d = test::paper_design('C');
  std::vector<Reading> r;
  double t = 0;
  for (const Installation& in : d.installations) {
    for (double a : d.angles_deg) r.push_back({in.id, a, 0.0, t += 10, std::nullopt, std::nullopt});
  }
  EXPECT_TRUE(readings_on_one_clock(d, r));
  for (double a : d.angles_deg)  // 1r again, at the end
    r.push_back({d.installations[0].id, a, 0.0, t += 10, std::nullopt, std::nullopt});
  EXPECT_TRUE(readings_on_one_clock(d, r));
  for (std::size_t i = 0; i < d.angles_deg.size(); ++i) *r[i].time_s -= 5;  // a fraction earlier
  EXPECT_TRUE(readings_on_one_clock(d, r));
  const std::size_t n = d.angles_deg.size();
  for (std::size_t i = n; i < 2 * n; ++i) *r[i].time_s -= 10.0 * n;  // 1t's clock restarted
  EXPECT_FALSE(readings_on_one_clock(d, r));
}

// The README's worked example prints what the README shows: every line of its output blocks
// ("..." aside) is printed by the commands it names, or is in the file they write.
TEST(Readme, FromTheInstrumentsTracePrintsWhatTheReadmeShows) {
  namespace fs = std::filesystem;
  const std::string section =
      readme_section("## Worked example: from the instrument's trace to identify");
  ASSERT_FALSE(section.empty());
  const fs::path dir =
      fs::temp_directory_path() / ("dbbkit_readme_tr_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir / "traces");
  const std::string src = DBBKIT_SOURCE_DIR;
  const std::string D = src + "/designs/paper-c-turntable.json";
  std::string traces;
  for (const char* id : {"1r", "1t", "1a", "2r", "2t", "3r", "3t"})
    traces += std::string(" --trace ") + id + "=traces/" + id + ".csv";
  std::string printed;
  for (
      const auto& [cmd, status] : std::vector<std::pair<std::string, int>>{
          {"simulate --design " + D + " --truth " + src +
               "/tests/data/truth_c_per_angle.json --seed 4 --out sim.csv --trace-out traces/",
           0},
          {"readings --design " + D + traces + " --out m.csv --report readings.html", 0},
          {"identify --design " + D + " --data m.csv --out id.json", 0},
          {"readings --design " + D +
               " --trace 1r=tests/data/trace_vendor_1r.csv --columns time=Sample,reading=Deviation "
               "--unit mm --sample-rate-hz 100 --out m1r.csv",
           0},
          {"readings --design " + D +
               " --trace 1r=tests/data/trace_vendor_1r.csv --columns time=Sample,reading=Deviation "
               "--unit mm --sample-rate-hz 100 --dwell-s 5 --out m5.csv",
           2}}) {
    // The vendor file by the path the README gives, relative to the source tree.
    const std::string at = cmd.find("tests/data/trace_vendor") != std::string::npos
                               ? "cd " + src + " && "
                               : "cd " + dir.string() + " && ";
    std::string c = cmd;
    if (at.find(src) != std::string::npos) {
      // Write its outputs into the test's directory, not the source tree.
      for (const char* f : {"m1r.csv", "m5.csv"}) {
        const std::size_t k = c.find(f);
        if (k != std::string::npos) c.replace(k, std::string(f).size(), (dir / f).string());
      }
    }
    const CliRun r = run_cli_shell(at + DBBKIT_CLI + " " + c);
    ASSERT_EQ(r.status, status) << c << "\n" << r.err;
    printed += r.out + r.err;
  }
  printed += slurp((dir / "m.csv").string());
  int checked = 0;
  for (const std::string& line : readme_lines_not_printed(section, printed, false, checked))
    ADD_FAILURE() << "README line not printed:\n" << line;
  EXPECT_GE(checked, 7);
  fs::remove_all(dir);
}

}  // namespace
}  // namespace dbbkit
