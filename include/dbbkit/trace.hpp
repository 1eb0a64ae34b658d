#pragma once
// Readings from the instrument's own time series (formats: "Raw traces"): the machine dwells at
// each angle of a sweep while the bar reads a constant length; between dwells the axes move and
// the length wanders. find_plateaus finds where the trace stood still; readings_from_trace
// matches the plateaus in order to the program's stops of one installation and takes each
// plateau's settled mean as the reading.
//
// A plateau: a run of windows of window_s whose scatter stays within the sample noise and whose
// means agree with their neighbours' within their standard errors (the noise is the lower
// quartile of the windows' scatters unless given: a quarter of the trace or more must be still),
// at least min_share of the programmed dwell long. A bar excursion that turns at a flat top is
// still for far less than that and is no plateau; a move that leaves the bar's length unchanged
// cannot be seen, and its two dwells are one. Its settled part
// starts where the signal, smoothed over settle_window_s, has come within the noise of the
// plateau's final level (the transient after the move left out) and ends window_s before the
// plateau's end (the next move's onset left out).

#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "dbbkit/design.hpp"
#include "dbbkit/measurement.hpp"
#include "dbbkit/warning.hpp"

namespace dbbkit {

// One installation's samples, in time order.
struct Trace {
  std::vector<double> time_s;
  std::vector<double> reading_um;
  // Where they were read, for a message that names a line (empty when the samples did not come
  // from a file): the reading column's name and unit ("um", "mm"), and the line of the first
  // sample of each run of samples on consecutive lines (the most runs kept: kMaxLineRuns).
  std::string reading_column, reading_unit;
  std::vector<std::pair<std::size_t, long>> line_runs;
  static constexpr std::size_t kMaxLineRuns = 100000;
  // The line of sample i (from 0), or 0 when it is not known.
  long line_of(std::size_t i) const;
};

struct DwellOptions {
  double dwell_s = 2.0;    // the programmed dwell at each reading position
  double min_share = 0.5;  // a plateau is at least this share of the dwell long
  double window_s = 0.1;   // the window of the stillness test
  // Still: the window's scatter <= scatter_factor times the sample noise, and its mean within
  // mean_factor standard errors (noise sqrt(2 / samples)) of its neighbours' means.
  double scatter_factor = 2.0;
  double mean_factor = 6.0;
  double settle_window_s = 0.05;  // smoothing of the settling test
  // The sample noise (standard deviation) in um; absent: estimated from the trace.
  std::optional<double> noise_um;
};

// The fastest drift [um/min] the stillness test reliably takes for standing still: one that moves
// a window's mean from its neighbour's by a quarter of the test's tolerance (mean_factor = 6
// standard errors of the difference: the noise must then exceed 4.5 of them, about 3e-6 a window,
// for a still window to fail) at this sample noise [um] (the stillness test's floor below it) and
// interval [s]. The boundary is statistical: at half the tolerance about one installation in 50
// lost a dwell, and twice this drift is sometimes read. simulate writes no trace of a faster
// drift; readings' refusal of a dwell count states it.
double max_still_drift_um_per_min(double noise_um, double sample_interval_s,
                                  const DwellOptions& options = {});
// The noise the stillness test uses for a sample noise [um]: at least its floor (5 nm).
double stillness_noise_um(double noise_um);

struct Plateau {
  double start_s = 0, end_s = 0;  // the still run
  double settled_start_s = 0, settled_end_s = 0;
  double level_um = 0;           // mean over the settled part
  double std_um = 0;             // the samples' standard deviation over it
  long samples = 0;              // in the settled part
  std::size_t first_sample = 0;  // the settled part's first sample (index into the trace)
};

struct PlateauSearch {
  std::vector<Plateau> plateaus;
  double noise_um = 0;           // the sample noise used
  double sample_interval_s = 0;  // the median interval between samples
};

// Throws InputError(source, ...) for a trace that is not one: fewer than 10 or more than
// limits::kMaxTraceSamples samples, times not finite or not increasing, readings not finite or
// beyond limits::kMaxTraceReading_um, times that look like milliseconds since 1970, a gap
// between two samples beyond limits::kMaxTraceGap_s and kMaxTraceGapFactor median intervals.
PlateauSearch find_plateaus(const Trace& trace, const DwellOptions& options,
                            const std::string& source);

// The program's stops of one installation (design index) with readings, in the order it makes
// them (its angles, Design::angles_of, sorted, ccw increasing, cw decreasing; ccw first with both):
// consecutive readings at one position without a move between them (the turn of the sweep with
// both) are one stop of several readings.
struct Stop {
  double angle_deg = 0;
  std::vector<Sweep> sweeps;  // one per reading taken there, in order
};
std::vector<Stop> program_stops(const Design& design, int installation,
                                const std::vector<Sweep>& sweeps);
// The sweeps a program makes by name: "ccw", "cw" or "both" (ccw then cw), or a list of them in
// order ("ccw,cw,ccw", as a truth's schedule.sweeps; at most limits::kMaxSweeps); throws
// InputError(source, "", ...) for another name.
std::vector<Sweep> sweeps_by_name(const std::string& name, const std::string& source);

struct TraceReadings {
  // In the order taken, each with time_s (the middle of its samples), sweep, std_um (their
  // scatter) and samples (their number).
  std::vector<Reading> readings;
  PlateauSearch search;
  std::vector<Warning> warnings;  // plateaus of abnormal scatter or length
};

// Throws InputError(option_name("--trace"), the id) when `installation` is no installation of
// the design, listing its ids (and the one it may be, written in another case).
void check_trace_installation(const Design& design, const std::string& installation);

// The readings of installation `installation` (its id) from its trace. A stop of several
// readings is split into equal consecutive parts of its settled plateau. Throws InputError
// naming the installation, both counts and the times of the plateaus found when the plateaus
// are not as many as the stops, and when the trace does not begin still (the recording started
// during a move: its first stop's dwell missing, a last one after the program's stops); and
// InputError(source, the line and column, or the sample) for a reading beyond the instrument's
// range (the unit of the reading column named as the likely cause).
TraceReadings readings_from_trace(const Design& design, const std::string& installation,
                                  const Trace& trace, const std::vector<Sweep>& sweeps,
                                  const DwellOptions& options, const std::string& source);

// Puts the readings of several traces on the test's clock. `start_s`: when each trace's clock
// read zero on the test's clock, by installation id, for every installation of the readings or
// for none. Throws InputError(source, id) when some have a start and others not, and
// InputError(source) when with the starts two installations overlap in time. Without starts,
// returns the warning (kind trace_clock) when the traces' times overlap (each kept its own
// clock: effects over the whole test cannot be formed).
std::optional<Warning> put_on_test_clock(const Design& design, std::vector<Reading>& readings,
                                         const std::map<std::string, double>& start_s,
                                         const std::string& source);

// A trace as the instrument would record one installation's run (simulate --trace): a first
// plateau of extra length (capture started before), then for each stop its dwell at its level
// (a stop of several readings holds their mean: without a move the bar does not change), a move to
// the next stop with a bar excursion (a smooth bump of random sign and size up to excursion_um) and
// servo jitter, a damped settling oscillation after it, sample noise, the instrument's resolution,
// a drift on the trace's clock, and a last plateau of extra length.
struct TraceSimulation {
  double rate_hz = 1000;
  double dwell_s = 2.0;
  double first_extra_s = 1.5, last_extra_s = 1.5;  // beyond the dwell of the first and last stop
  double move_s_min = 1.0, move_s_max = 3.0;       // each move's duration, uniform
  double excursion_um = 20;  // a move's bump: uniform in [0.2, 1] times this, either sign
  double jitter_um = 0.3;    // servo jitter while moving (normal)
  double settle_um = 3;      // the settling oscillation's amplitude after a move
  double settle_tau_s = 0.08, settle_hz = 12;
  double noise_um = 0.15;       // sample noise (normal)
  double resolution_um = 0.01;  // the readings' quantum (0: none)
  double drift_um_per_min = 0;
  std::uint64_t seed = 1;
};

struct SimulatedTrace {
  Trace trace;
  // Per reading in the order taken: its level (the given reading; a stop's mean) and when its
  // dwell was.
  std::vector<double> level_um;
  std::vector<std::pair<double, double>> dwell_s;
  // With the readings' times: the test's clock when the trace's read zero, and what readings
  // --dwell-s should be (the shortest dwell a reading had, and little more than twice the first
  // and the last plateau: the first is cut where the test's clock begins).
  std::optional<double> zero_s, shortest_dwell_s;
};

// `levels`: one per reading of program_stops(design, installation, sweeps), in order. `times_s`
// (empty, or one per reading on the test's clock): the trace follows them, each move centred
// between the last reading of one stop and the first of the next, the machine standing still from
// one move to the next (longer than the programmed dwell when the schedule leaves time); throws
// InputError("schedule", "per_reading_s") when a stop's time is shorter than its dwell, and
// InputError("--trace-out") before making a trace of more than limits::kMaxTraceSamples.
SimulatedTrace simulate_trace(const std::vector<Stop>& stops, const std::vector<double>& levels,
                              const TraceSimulation& options,
                              const std::vector<double>& times_s = {});

}  // namespace dbbkit
