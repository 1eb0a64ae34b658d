#pragma once
// Running the command line from a test: exit status, stdout and stderr.

#include <sys/wait.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

namespace dbbkit {

struct CliRun {
  int status = -1;
  std::string out, err;
};

inline std::string slurp(const std::string& path) {
  std::ifstream in(path);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

// Runs a shell command line, capturing its stdout and stderr.
inline CliRun run_cli_shell(const std::string& command) {
  const auto dir = std::filesystem::temp_directory_path();
  const std::string out = (dir / ("dbbkit_cli_out_" + std::to_string(::getpid()))).string();
  const std::string err = out + ".err";
  const std::string cmd = command + " > " + out + " 2> " + err;
  const int raw = std::system(cmd.c_str());
  CliRun r;
  r.status = WIFEXITED(raw) ? WEXITSTATUS(raw) : -1;
  r.out = slurp(out);
  r.err = slurp(err);
  std::filesystem::remove(out);
  std::filesystem::remove(err);
  return r;
}

inline CliRun run_cli(const std::string& args) {
  return run_cli_shell(std::string(DBBKIT_CLI) + " " + args);
}

}  // namespace dbbkit
