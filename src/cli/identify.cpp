#include <iostream>
#include <memory>

#include "commands.hpp"
#include "dbbkit/identify.hpp"
#include "dbbkit/io/design_io.hpp"
#include "dbbkit/io/measurement_io.hpp"
#include "dbbkit/io/output.hpp"
#include "dbbkit/io/result_io.hpp"

namespace dbbkit::cli {

namespace {
struct IdentifyArgs {
  std::string design, data, out;
};
}  // namespace

Runner add_identify(CLI::App& app) {
  auto args = std::make_shared<IdentifyArgs>();
  CLI::App* sub = app.add_subcommand("identify", "Identify the six errors of the axis from DBB readings");
  sub->add_option("--design", args->design, "Design file (dbbkit.design/1)")->required();
  sub->add_option("--data", args->data, "Measurement file (CSV)")->required();
  sub->add_option("--out", args->out,
                  "Result JSON (dbbkit.identify/1); '-' or absent: JSON on stdout. "
                  "With a file, a summary table is printed on stdout");
  return [args]() {
    const Design design = io::read_design_file(args->design);
    const std::vector<Reading> readings = io::read_measurement_file(args->data, design);
    const IdentifyResult result = identify(design, readings);
    const nlohmann::json j = io::identify_to_json(design, readings, result, {args->design, args->data});
    io::write_output(args->out, j.dump(2) + "\n", {args->design, args->data});
    if (!args->out.empty() && args->out != "-") std::cout << io::identify_summary(design, result);
    return 0;
  };
}

}  // namespace dbbkit::cli
