#include "dbbkit/simulate.hpp"

#include <cmath>
#include <memory>
#include <optional>
#include <sstream>

#include "checks.hpp"
#include "commands.hpp"
#include "dbbkit/error.hpp"
#include "dbbkit/instrument.hpp"
#include "dbbkit/io/design_io.hpp"
#include "dbbkit/io/json_reader.hpp"
#include "dbbkit/io/measurement_io.hpp"
#include "dbbkit/io/output.hpp"
#include "dbbkit/io/text.hpp"
#include "dbbkit/io/trace_io.hpp"
#include "dbbkit/io/truth_io.hpp"
#include "dbbkit/trace.hpp"
#include "dbbkit/user_text.hpp"

namespace dbbkit::cli {

namespace {
struct SimulateArgs {
  std::string design, truth, out, setup_out, trace_out;
  std::optional<std::uint64_t> seed;
  bool quiet = false;
  TraceSimulation trace;
};

// An installation id as a file name: letters, digits, '_', '-' and '.', not first.
void check_file_id(const std::string& id) {
  const bool ok = !id.empty() && id.size() <= 64 && id[0] != '.' &&
                  id.find_first_not_of(
                      "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz"
                      "0123456789_-.") == std::string::npos;
  if (!ok) {
    throw InputError("--trace-out", quote_value(id),
                     "an installation id that names a trace file must be letters, digits, '_', "
                     "'-' or '.' (not first)");
  }
}

// Each installation's trace, its levels the simulated readings in the program's order (the
// truth's sweeps, else ccw). Throws InputError when the readings are not one per angle and sweep.
std::vector<std::pair<std::string, SimulatedTrace>> simulated_traces(
    const Design& design, const Truth& truth, const std::vector<Reading>& readings,
    TraceSimulation options, const std::string& source) {
  const std::vector<Sweep> sweeps =
      truth.schedule ? truth.schedule->sweeps : std::vector<Sweep>{Sweep::kCCW};
  if (truth.repeats != 1)
    throw InputError(source, "repeats", "a simulated trace takes one reading per angle and sweep");
  std::vector<std::pair<std::string, SimulatedTrace>> out;
  for (std::size_t i = 0; i < design.installations.size(); ++i) {
    const std::vector<Stop> stops = program_stops(design, static_cast<int>(i), sweeps);
    const std::size_t per_sweep =
        static_cast<std::size_t>(design.readings_per_sweep(static_cast<int>(i)));
    const std::string& id = design.installations[i].id;
    check_file_id(id);
    std::vector<const Reading*> own;
    for (const Reading& r : readings)
      if (r.installation == id) own.push_back(&r);
    if (own.size() != per_sweep * sweeps.size())
      throw std::logic_error("simulate --trace-out: readings not one per angle and sweep");
    // Sweep entry j holds readings [j per_sweep, (j + 1) per_sweep) (simulate.hpp); the stops
    // take them by angle in the program's order.
    std::vector<double> levels, times;
    bool timed = true;
    std::size_t entry = 0;
    std::vector<bool> used(own.size(), false);  // a return reading's angle is read twice
    for (const Stop& s : stops) {
      for (std::size_t q = 0; q < s.sweeps.size(); ++q, ++entry) {
        const std::size_t j = entry / per_sweep;
        const Reading* hit = nullptr;
        for (std::size_t k = j * per_sweep; k < (j + 1) * per_sweep && !hit; ++k) {
          if (own[k]->angle_deg == s.angle_deg && !used[k]) {
            hit = own[k];
            used[k] = true;
          }
        }
        if (!hit) throw std::logic_error("simulate --trace-out: no reading at a stop");
        levels.push_back(hit->reading_um);
        timed = timed && hit->time_s;
        times.push_back(hit->time_s.value_or(0.0));
      }
    }
    options.seed = options.seed * 1000003ULL + i;
    try {
      out.emplace_back(
          id, simulate_trace(stops, levels, options, timed ? times : std::vector<double>{}));
    } catch (const InputError& e) {
      if (e.source() == "--trace-out")
        throw InputError("--trace-out", "installation " + id, e.detail());
      throw e.source() == "schedule" ? e.with_source(source) : e;
    }
  }
  return out;
}
}  // namespace

Runner add_simulate(CLI::App& app) {
  auto args = std::make_shared<SimulateArgs>();
  CLI::App* sub =
      app.add_subcommand("simulate", "Synthetic readings of a design from a declared truth");
  sub->add_option("--design", args->design, "Design file (dbbkit.design/1)")->required();
  sub->add_option("--truth", args->truth, "Truth file (dbbkit.truth/1)")->required();
  sub->add_option("--seed", args->seed,
                  "Seed of the noise generator (overrides the truth file's seed)")
      ->transform(seed_value());
  sub->add_option("--out", args->out, "Measurement CSV; '-' or absent: stdout");
  sub->add_option(
      "--setup-out", args->setup_out,
      "The set-up errors used (dbbkit.setup-errors/1 JSON; exact geometry), drawn or given");
  CLI::Option* trace_out = sub->add_option(
      "--trace-out", args->trace_out,
      "Also a raw 1 kHz trace of each installation, as the instrument records it, to "
      "PREFIX<id>.csv (e.g. traces/): dwells at the readings, moves with bar "
      "excursions, settling, noise");
  sub->add_option("--trace-dwell-s", args->trace.dwell_s, "The traces' dwell at each angle [s]")
      ->check(finite_in(limits::kMinSimulatedDwell_s, limits::kMaxDwell_s))
      ->capture_default_str()
      ->needs(trace_out);
  sub->add_option("--trace-rate-hz", args->trace.rate_hz, "The traces' sample rate [Hz]")
      ->check(finite_in(limits::kMinSimulatedRate_hz, limits::kMaxSimulatedRate_hz))
      ->capture_default_str()
      ->needs(trace_out);
  sub->add_option("--trace-noise-um", args->trace.noise_um, "The traces' sample noise [um]")
      ->check(finite_in(0, limits::kMaxSimulatedTraceNoise_um))
      ->capture_default_str()
      ->needs(trace_out);
  sub->add_option("--trace-excursion-um", args->trace.excursion_um,
                  "The largest bar excursion of a move [um]")
      ->check(finite_in(0, limits::kMaxSimulatedExcursion_um))
      ->capture_default_str()
      ->needs(trace_out);
  sub->add_option("--trace-drift-um-per-min", args->trace.drift_um_per_min,
                  "A drift of the traces on their own clock [um/min]")
      ->check(
          finite_in(-limits::kMaxSimulatedDrift_um_per_min, limits::kMaxSimulatedDrift_um_per_min))
      ->capture_default_str()
      ->needs(trace_out);
  // simulate prints nothing but the files asked for; --quiet is accepted as by every command.
  sub->add_flag("--quiet", args->quiet,
                "Nothing on the terminal but the files asked for (the default)");
  return [args]() {
    // A trace whose bar drifts faster than the dwell finder reliably takes for still may lose
    // dwells, and readings would refuse it.
    const double still =
        max_still_drift_um_per_min(args->trace.noise_um, 1.0 / args->trace.rate_hz);
    if (std::abs(args->trace.drift_um_per_min) > still)
      throw InputError("--trace-drift-um-per-min", io::fmt_num(args->trace.drift_um_per_min, 6),
                       "at a sample noise of " + io::fmt_num(args->trace.noise_um, 6) + " um and " +
                           io::fmt_num(args->trace.rate_hz, 6) +
                           " Hz readings' dwell finder reliably takes a drift of at most " +
                           io::fmt_num(still, 3) +
                           " um/min for standing still (a quarter of its tolerance of neighbouring "
                           "windows' means); faster, it may lose dwells and refuse the traces (a "
                           "larger --trace-noise-um takes more)");
    std::vector<io::OutputTarget> targets = {{"--out", args->out.empty() ? "-" : args->out}};
    if (!args->setup_out.empty()) targets.push_back({"--setup-out", args->setup_out});
    const Design design = io::read_design_file(args->design);
    if (!args->setup_out.empty())
      require_ballbar(design, args->design,
                      "a set-up file (--setup-out: a probe's set-up is the truth's effects)");
    if (!args->trace_out.empty()) {
      require_ballbar(design, args->design, "a trace (--trace-out)");
      for (const Installation& in : design.installations) {
        check_file_id(in.id);
        targets.push_back({"--trace-out " + in.id, args->trace_out + in.id + ".csv"});
      }
    }
    io::OutputSet outputs(targets, {args->design, args->truth});
    const Truth truth = io::read_truth_file(args->truth);
    validate_truth(truth, design, args->truth);
    const std::optional<std::uint64_t> seed = args->seed ? args->seed : truth.seed;
    if (!seed && !truth.noiseless) {
      throw InputError(args->truth, "seed", "no seed: give --seed or \"seed\" in the truth file");
    }
    std::vector<Reading> readings;
    try {
      readings = simulate(design, truth, seed.value_or(0));
    } catch (const InputError& e) {
      throw e.source() == "truth" ? e.with_source(args->truth) : e;
    }
    std::ostringstream csv;
    io::write_measurements_csv(csv, readings, design);
    outputs.stage("--out", csv.str());
    if (!args->setup_out.empty()) {
      if (!truth.exact)
        throw InputError("--setup-out", "",
                         "set-up errors are simulated with \"geometry\": \"exact\" only");
      outputs.stage("--setup-out",
                    io::dump_json(io::setup_errors_to_json(
                        design, simulated_setup_errors(design, truth, seed.value_or(0)))) +
                        "\n");
    }
    if (!args->trace_out.empty()) {
      TraceSimulation options = args->trace;
      options.seed = seed.value_or(0);
      for (const auto& [id, sim] :
           simulated_traces(design, truth, readings, options, args->truth)) {
        std::vector<std::string> comments{
            "dbbkit simulate --trace-out: installation " + id + " of design " + design.name + ", " +
            std::to_string(sim.level_um.size()) + " dwells of " + io::fmt_num(options.dwell_s, 4) +
            " s at " + io::fmt_num(options.rate_hz, 4) + " Hz"};
        // The trace's clock starts at zero; with the truth's schedule, its zero on the test's.
        if (sim.zero_s && sim.shortest_dwell_s) {
          const double dwell = std::floor(*sim.shortest_dwell_s * 10) / 10;
          // The program's sweeps as readings --sweeps names them (the default ccw left out).
          std::string sweeps;
          for (const Sweep s :
               truth.schedule ? truth.schedule->sweeps : std::vector<Sweep>{Sweep::kCCW})
            sweeps += (sweeps.empty() ? "" : ",") + std::string(sweep_name(s));
          if (sweeps == "ccw,cw") sweeps = "both";
          if (sweeps == "ccw") sweeps.clear();
          comments.push_back("on the test's clock this trace starts at " +
                             io::fmt_num(*sim.zero_s, 6) +
                             " s; following the truth's schedule the machine stands still at "
                             "least " +
                             io::fmt_num(dwell, 4) + " s a reading: dbbkit readings --dwell-s " +
                             io::fmt_num(dwell, 4) + (sweeps.empty() ? "" : " --sweeps " + sweeps) +
                             " --start " + id + "=" + io::fmt_num(*sim.zero_s, 6));
        }
        std::ostringstream text;
        io::write_trace_csv(text, sim.trace, comments);
        outputs.stage("--trace-out " + id, text.str());
      }
    }
    outputs.commit();
    return 0;
  };
}

}  // namespace dbbkit::cli
