#pragma once
// Running the command line from a test: exit status, stdout and stderr.

#include <sys/wait.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <sstream>
#include <string>
#include <vector>

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

// The README's section that begins with `title` (up to the next "## " heading), or empty when
// the README has none.
inline std::string readme_section(const std::string& title) {
  const std::string readme = slurp(DBBKIT_SOURCE_DIR "/README.md");
  const std::size_t from = readme.find(title);
  if (from == std::string::npos) return "";
  return readme.substr(from, readme.find("\n## ", from + 1) - from);
}

// The README section's output lines (those of its plain ``` blocks and, with table_rows, its
// Markdown table rows; "...", empty lines and lines holding `skip` aside) that `printed` does
// not hold, and how many were checked.
inline std::vector<std::string> readme_lines_not_printed(const std::string& section,
                                                         const std::string& printed,
                                                         bool table_rows, int& checked,
                                                         const std::string& skip = "") {
  std::vector<std::string> missing;
  std::istringstream in(section);
  bool in_text = false, in_block = false;
  checked = 0;
  for (std::string line; std::getline(in, line);) {
    if (line.rfind("```", 0) == 0) {
      in_text = !in_block && line == "```";
      in_block = !in_block;
      continue;
    }
    const bool row = table_rows && !in_block && line.rfind("| ", 0) == 0 &&
                     line.find("---") == std::string::npos;
    if (!((in_block && in_text) || row) || line == "..." || line.empty() ||
        (!skip.empty() && line.find(skip) != std::string::npos))
      continue;
    if (printed.find(line) == std::string::npos) missing.push_back(line);
    ++checked;
  }
  return missing;
}

}  // namespace dbbkit
