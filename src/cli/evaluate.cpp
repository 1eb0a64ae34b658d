#include <iostream>
#include <memory>
#include <optional>

#include "commands.hpp"
#include "uncertainty_options.hpp"
#include "dbbkit/error.hpp"
#include "dbbkit/io/design_io.hpp"
#include "dbbkit/io/output.hpp"
#include "dbbkit/io/result_io.hpp"
#include "dbbkit/observability.hpp"

namespace dbbkit::cli {

namespace {
struct EvaluateArgs {
  std::string design, out;
  std::optional<double> reference_length_mm;
};
}  // namespace

Runner add_evaluate(CLI::App& app) {
  auto args = std::make_shared<EvaluateArgs>();
  CLI::App* sub = app.add_subcommand("evaluate", "What a design can identify, and how well, before measuring");
  sub->add_option("--design", args->design, "Design file (dbbkit.design/1)")->required();
  sub->add_option("--reference-length-mm", args->reference_length_mm,
                  "Lever arm converting angular uncertainty to um (default: the design's reference_length_mm)");
  sub->add_option("--out", args->out, "Result JSON (dbbkit.evaluate/1); '-': stdout. The summary goes to stdout otherwise");
  auto unc = std::make_shared<UncertaintyArgs>();
  add_uncertainty_options(sub, unc);
  return [args, unc]() {
    const Design design = io::read_design_file(args->design);
    const std::optional<double> ref = args->reference_length_mm ? args->reference_length_mm : design.reference_length_mm;
    if (!ref || !(*ref > 0)) {
      throw InputError(args->design, "reference_length_mm",
                       "needed to express angular uncertainty in um (or give --reference-length-mm)");
    }
    const Evaluation ev = evaluate_design(design, *ref);
    std::optional<MonteCarloResult> mc;
    if (unc->monte_carlo) mc = monte_carlo_a_priori(design, unc->coverage, unc->mc);
    if (!args->out.empty()) {
      io::write_output(args->out, io::evaluate_to_json(design, ev, args->design, mc ? &*mc : nullptr).dump(2) + "\n",
                       {args->design});
    }
    if (args->out != "-") {
      std::cout << io::evaluate_summary(design, ev);
      if (mc) std::cout << io::monte_carlo_summary(*mc);
    }
    return 0;
  };
}

}  // namespace dbbkit::cli
