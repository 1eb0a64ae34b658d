// libFuzzer target: the command line's options. The input is an argument vector
// (arguments separated by NUL or newline bytes) parsed by the real command line,
// never run: nothing is read or written. A parse must end in success or in a
// CLI::ParseError (exit status 2 for the user); any other exception or a crash is a
// bug. After a successful parse, no value that the range checks refuse may have
// got through (in any of the forms --opt v, --opt=v, repeated options).
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <set>
#include <string>
#include <vector>

#include "app.hpp"
#include "dbbkit/parallel.hpp"

namespace {

bool number_in(const std::string& s, double lo, double hi) {
  char* end = nullptr;
  const double x = std::strtod(s.c_str(), &end);
  return end == s.c_str() + s.size() && std::isfinite(x) && x >= lo && x <= hi;
}

void check(const CLI::App& sub) {
  static const std::set<std::string> paths = {
      "--design", "--data",      "--out",       "--report",        "--summary",
      "--kit",    "--result",    "--reference", "--pareto-csv",    "--map-csv",
      "--truth",  "--setup-out", "--baseline",  "--write-baseline"};
  for (const CLI::Option* opt : sub.get_options()) {
    if (opt->count() == 0) continue;
    const std::string name = opt->get_name();
    for (const std::string& v : opt->results()) {
      if (paths.count(name) && v.empty()) __builtin_trap();
      if ((name == "--threads" || name == "--mc-threads") && !number_in(v, 0, dbbkit::kMaxThreads))
        __builtin_trap();
      if (name == "--level" && !number_in(v, 1e-6, 0.2)) __builtin_trap();
      if (name == "--coverage" && !number_in(v, 0.5, 0.9999)) __builtin_trap();
      if (name == "--reference-length-mm" && !number_in(v, 1e-3, 1e4)) __builtin_trap();
      if ((name == "--seed" || name == "--mc-seed") && (v.empty() || v[0] == '-')) __builtin_trap();
    }
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size > 4096) return 0;
  std::vector<std::string> args;
  std::string cur;
  for (std::size_t i = 0; i < size; ++i) {
    const char c = static_cast<char>(data[i]);
    if (c == '\0' || c == '\n') {
      args.push_back(cur);
      cur.clear();
    } else {
      cur += c;
    }
  }
  args.push_back(cur);
  std::vector<const char*> argv = {"dbbkit"};
  for (const std::string& a : args) argv.push_back(a.c_str());
  const auto cl = dbbkit::cli::make_command_line();
  try {
    cl->app.parse(static_cast<int>(argv.size()), argv.data());
  } catch (const CLI::ParseError&) {
    return 0;
  }
  for (const auto& [sub, run] : cl->commands) {
    if (sub->parsed()) check(*sub);
  }
  return 0;
}
