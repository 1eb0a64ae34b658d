#include <iostream>

#include "app.hpp"
#include "dbbkit/error.hpp"
#include "dbbkit/io/escape.hpp"
#include "dbbkit/io/output.hpp"
#include "report_options.hpp"

int main(int argc, char** argv) {
  dbbkit::cli::set_command_line(argc, argv);
  const std::unique_ptr<dbbkit::cli::CommandLine> cl = dbbkit::cli::make_command_line();
  try {
    cl->app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    // Help and the version as the parser writes them; an error with its values escaped, as
    // every message of dbbkit (an option's value may hold any bytes).
    if (e.get_exit_code() == 0) return cl->app.exit(e);
    std::cerr << "dbbkit: error: " << dbbkit::io::terminal_text(e.what())
              << "\nRun with --help for more information.\n";
    return 2;
  }
  dbbkit::io::install_cleanup_handlers();
  try {
    for (auto& [sub, run] : cl->commands) {
      if (sub->parsed()) {
        const int status = run();
        dbbkit::io::finish_stdout();
        return status;
      }
    }
  } catch (const dbbkit::InputError& e) {
    std::cerr << "dbbkit: error: " << dbbkit::cli::as_command_line(e).what() << "\n";
    return 2;
  } catch (const std::bad_alloc&) {
    std::cerr << "dbbkit: error: not enough memory for these inputs ("
              << dbbkit::cli::command_line().substr(0, 300) << ")\n";
    return 2;
  } catch (const std::exception& e) {
    std::cerr << "dbbkit: internal error: " << e.what() << "\n";
    return 3;
  }
  return 2;
}
