#include "dbbkit/io/gnuplot.hpp"

#include <fcntl.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <sstream>
#include <thread>
#include <vector>

#include "dbbkit/error.hpp"
#include "dbbkit/io/json_reader.hpp"
#include "dbbkit/io/output.hpp"

namespace dbbkit::io {

std::string gnuplot_number(double x) {
  if (!std::isfinite(x)) return "NaN";
  std::ostringstream s;
  s << std::setprecision(10) << x;
  return s.str();
}

namespace {
// The longest a plot may take.
constexpr int kPlotTimeout_s = 120;
}  // namespace

std::string gnuplot_svg(const std::string& script, int width_px, int height_px) {
  // A private directory (mkdtemp, mode 0700) holds the script, the plot and gnuplot's
  // messages: nothing in a shared temporary directory is ever opened by a guessable
  // name. The directory and its files are known to the signal handlers (output.hpp).
  std::filesystem::path tmp;
  {
    std::error_code ec;
    tmp = std::filesystem::temp_directory_path(ec);
    if (ec) {
      const char* env = std::getenv("TMPDIR");
      throw InputError("--report", "",
                       std::string("the plots need a temporary directory and TMPDIR=") +
                           (env ? env : "") + " is not one (" + ec.message() + ")");
    }
  }
  std::string dir = (tmp / "dbbkit-plot-XXXXXX").string();
  if (!::mkdtemp(dir.data())) {
    throw InputError("--report", "",
                     "cannot create a temporary directory for gnuplot in " + tmp.string() + " (" +
                         std::strerror(errno) + ")");
  }
  const int dir_slot = internal::register_temporary(dir, true);
  const std::string gp = dir + "/plot.gp", svg = dir + "/plot.svg", log = dir + "/plot.log";
  std::vector<int> slots;
  for (const std::string& f : {gp, svg, log}) slots.push_back(internal::register_temporary(f));
  auto cleanup = [&]() {
    for (const std::string& f : {gp, svg, log}) ::unlink(f.c_str());
    ::rmdir(dir.c_str());
    for (int s : slots) internal::unregister_temporary(s);
    internal::unregister_temporary(dir_slot);
  };
  std::string out, err;
  int status = -1, signal = 0;
  bool not_found = false, timed_out = false;
  {
    std::ofstream f(gp);
    f << "set terminal svg size " << width_px << "," << height_px
      << " noenhanced font 'sans,11' background rgb 'white'\n"
      << "set output " << gnuplot_quote(svg) << "\nset datafile missing NaN\n"
      << script << "\nunset output\n";
  }
  // gnuplot runs as a child of this process (not through a shell), its messages to the log.
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, STDIN_FILENO, "/dev/null", O_RDONLY, 0);
  posix_spawn_file_actions_addopen(&actions, STDOUT_FILENO, log.c_str(),
                                   O_WRONLY | O_CREAT | O_TRUNC, 0600);
  posix_spawn_file_actions_adddup2(&actions, STDOUT_FILENO, STDERR_FILENO);
  std::string arg0 = "gnuplot";
  std::string arg1 = gp;
  char* argv[] = {arg0.data(), arg1.data(), nullptr};
  pid_t pid = 0;
  const int rc = ::posix_spawnp(&pid, "gnuplot", &actions, nullptr, argv, environ);
  posix_spawn_file_actions_destroy(&actions);
  if (rc != 0) {
    not_found = rc == ENOENT;
  } else {
    // A plot takes well under a second; a gnuplot that hangs is stopped after kPlotTimeout_s.
    int wstatus = 0;
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(kPlotTimeout_s);
    for (;;) {
      const pid_t done = ::waitpid(pid, &wstatus, WNOHANG);
      if (done == pid || (done < 0 && errno != EINTR)) break;
      if (std::chrono::steady_clock::now() > deadline) {
        ::kill(pid, SIGKILL);
        while (::waitpid(pid, &wstatus, 0) < 0 && errno == EINTR) {
        }
        timed_out = true;
        break;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    status = WIFEXITED(wstatus) ? WEXITSTATUS(wstatus) : -1;
    signal = WIFSIGNALED(wstatus) ? WTERMSIG(wstatus) : 0;
    if (status == 0 && std::filesystem::exists(svg)) out = read_text_file(svg);
    if (std::filesystem::exists(log)) err = read_text_file(log);
  }
  cleanup();
  if (out.empty()) {
    std::string why;
    if (not_found) {
      why = "gnuplot draws the plots and was not found; install gnuplot-nox (./setup.sh does)";
    } else if (timed_out) {
      why = "gnuplot did not finish a plot in " + std::to_string(kPlotTimeout_s) + " s";
    } else {
      why = "gnuplot failed (" +
            (signal ? "killed by signal " + std::to_string(signal)
                    : "exit status " + std::to_string(status)) +
            (err.empty() ? std::string(", no message") : "): " + err.substr(0, 400));
      if (err.empty()) why += ")";
    }
    throw InputError("--report", "", why);
  }
  // Drop the XML prolog and DOCTYPE: the SVG is inlined in HTML.
  const size_t start = out.find("<svg");
  return start == std::string::npos ? out : out.substr(start);
}

}  // namespace dbbkit::io
