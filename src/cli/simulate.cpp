#include "dbbkit/simulate.hpp"

#include <memory>
#include <optional>
#include <sstream>

#include "checks.hpp"
#include "commands.hpp"
#include "dbbkit/error.hpp"
#include "dbbkit/io/design_io.hpp"
#include "dbbkit/io/json_reader.hpp"
#include "dbbkit/io/measurement_io.hpp"
#include "dbbkit/io/output.hpp"
#include "dbbkit/io/truth_io.hpp"

namespace dbbkit::cli {

namespace {
struct SimulateArgs {
  std::string design, truth, out, setup_out;
  std::optional<std::uint64_t> seed;
  bool quiet = false;
};
}  // namespace

Runner add_simulate(CLI::App& app) {
  auto args = std::make_shared<SimulateArgs>();
  CLI::App* sub =
      app.add_subcommand("simulate", "Synthetic readings of a design from a declared truth");
  sub->add_option("--design", args->design, "Design file (dbbkit.design/1)")->required();
  sub->add_option("--truth", args->truth, "Truth file (dbbkit.truth/1)")->required();
  sub->add_option("--seed", args->seed,
                  "Seed of the noise generator (overrides the truth file's seed)")
      ->check(seed_value());
  sub->add_option("--out", args->out, "Measurement CSV; '-' or absent: stdout");
  sub->add_option(
      "--setup-out", args->setup_out,
      "The set-up errors used (dbbkit.setup-errors/1 JSON; exact geometry), drawn or given");
  // simulate prints nothing but the files asked for; --quiet is accepted as by every command.
  sub->add_flag("--quiet", args->quiet,
                "Nothing on the terminal but the files asked for (the default)");
  return [args]() {
    std::vector<io::OutputTarget> targets = {{"--out", args->out.empty() ? "-" : args->out}};
    if (!args->setup_out.empty()) targets.push_back({"--setup-out", args->setup_out});
    io::OutputSet outputs(targets, {args->design, args->truth});
    const Design design = io::read_design_file(args->design);
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
    io::write_measurements_csv(csv, readings);
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
    outputs.commit();
    return 0;
  };
}

}  // namespace dbbkit::cli
