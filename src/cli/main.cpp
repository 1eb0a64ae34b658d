#include <iostream>
#include <string>

#include "app.hpp"
#include "dbbkit/error.hpp"
#include "dbbkit/io/escape.hpp"
#include "dbbkit/io/output.hpp"
#include "report_options.hpp"

namespace {

// The parser's message in dbbkit's words where it has its own: an option given more than once.
std::string parse_error_text(const CLI::ParseError& e) {
  const std::string what = e.what();
  const std::string said = ": At Most 1 required but received ";
  if (const std::size_t at = what.find(said); at != std::string::npos)
    return what.substr(0, at) + ": given " + what.substr(at + said.size()) + " times; give it once";
  return what;
}

}  // namespace

int main(int argc, char** argv) {
  dbbkit::cli::set_command_line(argc, argv);
  const std::unique_ptr<dbbkit::cli::CommandLine> cl = dbbkit::cli::make_command_line();
  try {
    cl->app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    // Help and the version as the parser writes them; an error with its values escaped, as
    // every message of dbbkit (an option's value may hold any bytes).
    if (e.get_exit_code() == 0) return cl->app.exit(e);
    std::cerr << "dbbkit: error: " << dbbkit::io::terminal_text(parse_error_text(e))
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
