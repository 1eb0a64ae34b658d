#include "dbbkit/chain.hpp"

#include <iostream>
#include <memory>

#include "checks.hpp"
#include "commands.hpp"
#include "dbbkit/io/chain_io.hpp"
#include "dbbkit/io/hashing.hpp"
#include "dbbkit/io/json_reader.hpp"
#include "dbbkit/io/machine_io.hpp"
#include "dbbkit/io/output.hpp"
#include "dbbkit/io/result_read.hpp"

namespace dbbkit::cli {

namespace {
struct ChainArgs {
  std::string machine, out;
  std::vector<std::string> results;
  double coverage = 0.95;
  bool quiet = false;
};
}  // namespace

Runner add_chain(CLI::App& app) {
  auto args = std::make_shared<ChainArgs>();
  CLI::App* sub = app.add_subcommand(
      "chain",
      "The results of a machine's rotary axes combined on the controller's reference: each "
      "axis' location errors in its carrier's body, and the chain terms (the distance between "
      "two axis lines, their squareness), each with its uncertainty");
  sub->add_option("--machine", args->machine, "Machine file (dbbkit.machine/1)")->required();
  sub->add_option("results", args->results,
                  "identify or diagnose results (--out) of the machine's axes, one per axis")
      ->required();
  sub->add_option("--out", args->out, "JSON result (dbbkit.chain/1); '-': stdout");
  sub->add_option("--coverage", args->coverage,
                  "Coverage probability of U (default 0.95; normal, k from it)")
      ->check(finite_in(limits::kMinCoverage, limits::kMaxCoverage));
  sub->add_flag("--quiet", args->quiet, "Nothing on the terminal but the files asked for");
  return [args]() {
    std::vector<std::string> inputs = {args->machine};
    inputs.insert(inputs.end(), args->results.begin(), args->results.end());
    std::vector<io::OutputTarget> targets;
    if (!args->out.empty()) targets.push_back({"--out", args->out});
    io::OutputSet outputs(targets, inputs);
    const Machine m = io::read_machine_file(args->machine);
    std::vector<ChainInput> in;
    for (const std::string& r : args->results) {
      const std::string text = io::read_json_file(r);  // once: a pipe gives its bytes once
      in.push_back(io::chain_input(m, io::result_from_text(text, r)));
      in.back().sha256 = io::sha256_hex(text);
    }
    const ChainResult c = chain_machine(m, in, args->coverage);
    if (!args->out.empty())
      outputs.stage("--out", io::dump_json(io::chain_to_json(c, m, args->machine,
                                                             io::sha256_file(args->machine))) +
                                 "\n");
    outputs.commit();
    if (args->out != "-" && !args->quiet) std::cout << io::chain_text(c, m);
    return 0;
  };
}

}  // namespace dbbkit::cli
