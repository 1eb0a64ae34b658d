#pragma once
// The documented limits of what dbbkit accepts. A value beyond one is bad input
// (InputError naming the file and key, or the option; exit status 2), never a
// silent overflow, a loss of rank from round-off or an exhausted memory. Each limit
// is far beyond any real double ball bar test; docs/formats.md, "Limits", lists them.

#include <cstddef>

namespace dbbkit::limits {

// |L|, |D|, |H| of a ball, a bar length, the reference length, a travel bound [mm]:
// 10 m. Beyond it the lever arms (1e-3 * e[urad] * P[mm]) leave the range in which
// the equilibrated Jacobian keeps its rank in double precision.
constexpr double kMaxLength_mm = 10000.0;
// Standard uncertainty or half-width of the reading noise [um]: 1e-4 um (far below
// any instrument's resolution) to 1e4 um (10 mm, the range of a ballbar).
constexpr double kMinNoise_um = 1e-4;
constexpr double kMaxNoise_um = 1e4;
// Order K of a series model (Fourier: 2K + 1 coefficients per error).
constexpr int kMaxSeriesOrder = 100;
// Measured angles of one design, installations of one design.
constexpr std::size_t kMaxAngles = 100000;
constexpr std::size_t kMaxInstallations = 10000;
// Spheres of one probe design (three channels each): a probing cycle's handful, with room.
constexpr std::size_t kMaxSpheres = 100;
// Poses of one predict file (100,000: about 10 s and 0.6 GB with the JSON written).
constexpr std::size_t kMaxPoses = 100000;
// Readings of one test verify checks: their covariance is dense (n x n; 5,000: 0.2 GB and
// seconds for its Cholesky factor).
constexpr std::size_t kMaxVerifyReadings = 5000;
// A map's radius other than 0 (the axis line): at least 1 um. Closer to the axis, the 360
// points of a circle would coincide at the results' resolution (1e-6 mm).
constexpr double kMinGridRadius_mm = 1e-3;
// Sweeps of one installation (a truth's schedule, readings --sweeps as a list).
constexpr std::size_t kMaxSweeps = 100;
// Readings of one measurement file or one simulation.
constexpr std::size_t kMaxReadings = 10000000;
// Bytes of one input file (design, kit, truth, measurement, baseline); a longer or
// endless input (a FIFO, /dev/zero) is refused once this much has been read.
constexpr std::size_t kMaxInputBytes = std::size_t{512} << 20;
// Bytes of one JSON input (design, kit, truth, tolerances, baseline, result): parsing takes
// about 20 times the text's size in memory, so 64 MiB of JSON costs about 1.3 GB. The
// largest design the other limits allow (100,000 angles, 10,000 installations) is about
// 5 MB. And the depth of its nesting (a design nests 4 levels).
constexpr std::size_t kMaxJsonBytes = std::size_t{64} << 20;
constexpr std::size_t kMaxJsonDepth = 64;
// Memory of the dense solver for one model: the Jacobian and its whitened copy
// (n x p each), the gain (p x n) and the covariance (p x p, twice), 8 bytes each:
//   8 (4 n p + 3 p^2) <= kMaxDenseBytes.
// A larger model is refused before any allocation, naming the size. For a per-angle
// C design of 7 installations this allows about 1,390 angles (a 0.26 deg step).
constexpr double kMaxDenseBytes = 4.0 * (1 << 30);
// Set-up standard uncertainty of a ball coordinate [mm]: 0 (none declared), or from 1e-7 mm
// (0.1 nm) to 100 mm.
constexpr double kMaxSetupStd_mm = 100.0;
constexpr double kMinSetupStd_mm = 1e-7;
// Standard uncertainty of a length offset or a centring component [um]: 0 (none declared), or
// from 1e-4 um (as the reading noise) to 1e4 um. A positive value below the least enters the
// prior as 1 / u^2 beyond the range of a double (1e-200 made every result NaN).
constexpr double kMaxSetupStd_um = 1e4;
constexpr double kMinSetupStd_um = 1e-4;

// Raw traces (readings, simulate --trace-out, Measurements.from_trace). The most samples of one
// trace, read or simulated (14 h at 1 kHz; 16 bytes a sample in memory); the longest line of a
// trace file (a file without line ends, /dev/zero, stops there); the sample rate that turns a
// sample index into seconds; the largest reading's size (1 m: beyond any ballbar's range, and
// a mm column times 1000 stays finite).
constexpr std::size_t kMaxTraceSamples = 50'000'000;
constexpr std::size_t kMaxTraceLineBytes = 65536;
constexpr double kMinTraceSampleRate_hz = 1e-3;
constexpr double kMaxTraceSampleRate_hz = 1e7;
constexpr double kMaxTraceReading_um = 1e6;
// A gap between two samples of more than kMaxTraceGapFactor times the median interval and more
// than kMaxTraceGap_s is a clock jump or two recordings joined, not a trace.
constexpr double kMaxTraceGapFactor = 1000;
constexpr double kMaxTraceGap_s = 60;

// A program's and a set-up sheet's options (ProgramOptions; `program`, `setup-sheet` and the
// Python module check the same ranges): the dwell at each reading [s], the feed between
// positions [mm/min], the largest bar-length change along a move [mm] (a ballbar reads within
// about +-1 mm), the tool number, the clearance plane's margin [mm].
constexpr double kMinDwell_s = 1e-3;
constexpr double kMaxDwell_s = 600;
constexpr double kMinFeed_mm_per_min = 1;
constexpr double kMaxFeed_mm_per_min = 60000;
constexpr double kMinPathTolerance_mm = 1e-4;
constexpr double kMaxPathTolerance_mm = 1;
constexpr int kMinToolNumber = 1;
// A part program's number (an O-number: `program --program-number`).
constexpr int kMinProgramNumber = 1;
constexpr int kMaxProgramNumber = 9999;
constexpr int kMaxToolNumber = 9999;
constexpr double kMinClearanceMargin_mm = 1;
constexpr double kMaxClearanceMargin_mm = 1000;
// The drift over the whole test a design must detect (a kit's require_drift_detection_um,
// `optimize --require-detect drift=UM`) [um]: at least 1 nm (a tenth of a ball bar's resolution;
// a smaller one would print as 0 in a result's six decimals), at most 1 mm.
constexpr double kMinRequiredDrift_um = 0.001;
constexpr double kMaxRequiredDrift_um = 1000;
// The program's dwell a trace is searched for (`readings --dwell-s`): at least 0.01 s, ten
// samples at 1 kHz; at most kMaxDwell_s. A dwell is at least kMinDwellShare of it long.
constexpr double kMinTraceDwell_s = 0.01;
constexpr double kMinDwellShare = 0.05;
// A trace's own start on the test's clock (`readings --start-s`) [s], at most 1e11 in size.
constexpr double kMaxTraceStart_s = 1e11;
// A simulated trace (`simulate --trace-*`): its dwell [s], sample rate [Hz], sample noise [um],
// a move's largest bar excursion [um] and a drift on its own clock [um/min].
constexpr double kMinSimulatedDwell_s = 0.05;
constexpr double kMinSimulatedRate_hz = 10;
constexpr double kMaxSimulatedRate_hz = 100000;
constexpr double kMaxSimulatedTraceNoise_um = 100;
constexpr double kMaxSimulatedExcursion_um = 1000;
constexpr double kMaxSimulatedDrift_um_per_min = 100;
// A set-up sheet's rounding of the ball positions [mm] (`setup-sheet --resolution-mm`, a kit's
// resolution_mm).
constexpr double kMinResolution_mm = 1e-3;
constexpr double kMaxResolution_mm = 10;

// Ranges of the run options (command-line options and the Python module's arguments).
// Coverage probability of an expanded uncertainty.
constexpr double kMinCoverage = 0.5;
constexpr double kMaxCoverage = 0.9999;
// The coverage factor k of a written expanded uncertainty (`compensation --k`).
constexpr double kMinCoverageFactor = 1;
constexpr double kMaxCoverageFactor = 10;
// The family-wise level of compare's tests.
constexpr double kMinCompareLevel = 1e-6;
constexpr double kMaxCompareLevel = 0.5;
// The number n of a Siemens swivel data record ($TC_CARR..[n]).
constexpr int kMinSwivelRecord = 1;
constexpr int kMaxSwivelRecord = 99;
// A design gate's relative tolerance of worst_std_um (`bench --tolerance`): below 1.
constexpr double kMaxBenchTolerance = 0.999999;
// The reference length that turns angular uncertainty into um [mm] (up to kMaxLength_mm).
constexpr double kMinReferenceLength_mm = 1e-3;
// diagnose: the family-wise level of each selection step, and the most effects added.
constexpr double kMinLevel = 1e-6;
constexpr double kMaxLevel = 0.2;
constexpr int kMaxEffects = 100;
// Monte Carlo: most trials, trials per adaptive batch, significant digits of u.
constexpr long kMinMonteCarloTrials = 1000;
constexpr long kMaxMonteCarloTrials = 1000000000;
constexpr long kMaxMonteCarloBatch = 100000000;
constexpr int kMinSignificantDigits = 1;
constexpr int kMaxSignificantDigits = 4;

}  // namespace dbbkit::limits
