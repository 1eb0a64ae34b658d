#pragma once
// One file per command: each registers its subcommand and returns the function
// that runs it once the command line is parsed. Runners return the exit status
// (0 success, 1 a check failed) and throw InputError for bad input (status 2).

#include <CLI/CLI.hpp>
#include <functional>

namespace dbbkit::cli {

using Runner = std::function<int()>;

Runner add_identify(CLI::App& app);
Runner add_simulate(CLI::App& app);
Runner add_evaluate(CLI::App& app);
Runner add_diagnose(CLI::App& app);
Runner add_optimize(CLI::App& app);
Runner add_bench(CLI::App& app);
Runner add_program(CLI::App& app);
Runner add_setup_sheet(CLI::App& app);
Runner add_compensation(CLI::App& app);
Runner add_compare(CLI::App& app);
Runner add_chain(CLI::App& app);
Runner add_readings(CLI::App& app);
Runner add_predict(CLI::App& app);
Runner add_verify(CLI::App& app);

}  // namespace dbbkit::cli
