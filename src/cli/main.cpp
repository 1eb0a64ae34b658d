#include <iostream>

#include "app.hpp"
#include "dbbkit/error.hpp"
#include "dbbkit/io/output.hpp"
#include "report_options.hpp"

int main(int argc, char** argv) {
  dbbkit::cli::set_command_line(argc, argv);
  const std::unique_ptr<dbbkit::cli::CommandLine> cl = dbbkit::cli::make_command_line();
  try {
    cl->app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    const int code = cl->app.exit(e);
    return code == 0 ? 0 : 2;
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
