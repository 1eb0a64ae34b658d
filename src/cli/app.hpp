#pragma once
// The command line as one object: every subcommand registered, every path option
// checked. main() parses and runs it; the option fuzzer (tests/fuzz/fuzz_cli.cpp)
// parses it only.

#include <CLI/CLI.hpp>
#include <memory>
#include <utility>
#include <vector>

#include "commands.hpp"
#include "dbbkit/error.hpp"

namespace dbbkit::cli {

struct CommandLine {
  CLI::App app{"dbbkit: identification of rotary-axis errors from double ball bar readings"};
  std::vector<std::pair<CLI::App*, Runner>> commands;
};

std::unique_ptr<CommandLine> make_command_line();

// Records the command line as given, for the conditions of a report.
void set_command_line(int argc, const char* const* argv);

// An error the library raised about one of its options ("options: max_trials") as the user
// wrote it ("--mc-max-trials"); any other error as it is.
InputError as_command_line(const InputError& e);

}  // namespace dbbkit::cli
