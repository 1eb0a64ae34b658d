#include <iostream>
#include <vector>

#include <set>
#include <string>

#include "checks.hpp"
#include "commands.hpp"
#include "dbbkit/io/output.hpp"
#include "report_options.hpp"
#include "dbbkit/error.hpp"

namespace dbbkit::cli {
namespace {
std::string g_command_line;
}
const std::string& command_line() { return g_command_line; }
}  // namespace dbbkit::cli

int main(int argc, char** argv) {
  {
    std::string line = "dbbkit";
    for (int i = 1; i < argc; ++i) line += std::string(" ") + argv[i];
    dbbkit::cli::g_command_line = line;
  }
  CLI::App app{"dbbkit: identification of rotary-axis errors from double ball bar readings"};
  app.set_version_flag("--version", std::string(DBBKIT_VERSION));
  app.require_subcommand(1);
  std::vector<std::pair<CLI::App*, dbbkit::cli::Runner>> commands;
  auto add = [&](dbbkit::cli::Runner (*adder)(CLI::App&)) {
    const size_t before = app.get_subcommands({}).size();
    dbbkit::cli::Runner run = adder(app);
    commands.emplace_back(app.get_subcommands({}).at(before), run);
  };
  add(dbbkit::cli::add_identify);
  add(dbbkit::cli::add_simulate);
  add(dbbkit::cli::add_evaluate);
  add(dbbkit::cli::add_diagnose);
  add(dbbkit::cli::add_optimize);
  add(dbbkit::cli::add_bench);
  // Every option that names a file: an empty path is refused where it is read.
  const std::set<std::string> path_options = {"--design", "--data",   "--out",       "--report",         "--summary",
                                              "--kit",    "--result", "--reference", "--pareto-csv",     "--map-csv",
                                              "--truth",  "--baseline", "--write-baseline", "designs"};
  for (auto& [sub, run] : commands) {
    for (CLI::Option* opt : sub->get_options()) {
      if (path_options.count(opt->get_name()) || path_options.count(opt->get_single_name())) {
        opt->check(dbbkit::cli::path_value());
      }
    }
  }
  dbbkit::io::install_cleanup_handlers();

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    const int code = app.exit(e);
    return code == 0 ? 0 : 2;
  }
  try {
    for (auto& [sub, run] : commands) {
      if (sub->parsed()) {
        const int status = run();
        dbbkit::io::finish_stdout();
        return status;
      }
    }
  } catch (const dbbkit::InputError& e) {
    std::cerr << "dbbkit: error: " << e.what() << "\n";
    return 2;
  } catch (const std::exception& e) {
    std::cerr << "dbbkit: internal error: " << e.what() << "\n";
    return 3;
  }
  return 2;
}
