#include "app.hpp"

#include <map>
#include <set>
#include <string>

#include "checks.hpp"
#include "report_options.hpp"

namespace dbbkit::cli {

namespace {
std::string g_command_line;
}

const std::string& command_line() { return g_command_line; }

void set_command_line(int argc, const char* const* argv) {
  std::string line = "dbbkit";
  for (int i = 1; i < argc; ++i) line += std::string(" ") + argv[i];
  g_command_line = line;
}

InputError as_command_line(const InputError& e) {
  // The library's Options structs and the options of the command line that set them.
  static const std::map<std::string, std::string> kOptions = {
      {"max_trials", "--mc-max-trials"},
      {"batch_trials", "--mc-batch"},
      {"significant_digits", "--mc-digits"},
      {"coverage_probability", "--coverage"},
      {"path_tolerance_mm", "--path-tolerance-mm"},
      {"dwell_s", "--dwell-s"},
      {"feed_mm_per_min", "--feed-mm-min"},
      {"tool_number", "--tool"},
      {"clearance_z_mm", "--clearance-z-mm"},
      {"clearance_margin_mm", "--clearance-margin-mm"},
      {"orient_code", "--orient-code"}};
  if (e.source() != "options" && e.source() != "program") return e;
  const auto it = kOptions.find(e.where());
  if (it == kOptions.end()) return e;
  return InputError(it->second, "", e.detail());
}

std::unique_ptr<CommandLine> make_command_line() {
  auto cl = std::make_unique<CommandLine>();
  CLI::App& app = cl->app;
  app.set_version_flag("--version", std::string(DBBKIT_VERSION));
  app.require_subcommand(1);
  auto add = [&](Runner (*adder)(CLI::App&)) {
    const size_t before = app.get_subcommands({}).size();
    Runner run = adder(app);
    cl->commands.emplace_back(app.get_subcommands({}).at(before), run);
  };
  add(add_identify);
  add(add_simulate);
  add(add_evaluate);
  add(add_diagnose);
  add(add_optimize);
  add(add_program);
  add(add_setup_sheet);
  add(add_compensation);
  add(add_compare);
  add(add_chain);
  add(add_predict);
  add(add_verify);
  add(add_readings);
  add(add_bench);
  // Every option that names a file: an empty path is refused where it is read.
  const std::set<std::string> path_options = {
      "--design",    "--data",       "--out",       "--report",         "--summary",
      "--kit",       "--result",     "--reference", "--pareto-csv",     "--map-csv",
      "--truth",     "--setup-out",  "--baseline",  "--write-baseline", "designs",
      "--trace-out", "--tolerances", "--machine",   "results"};
  for (auto& [sub, run] : cl->commands) {
    for (CLI::Option* opt : sub->get_options()) {
      if (path_options.count(opt->get_name()) || path_options.count(opt->get_single_name())) {
        opt->check(path_value());
      }
    }
  }
  return cl;
}

}  // namespace dbbkit::cli
