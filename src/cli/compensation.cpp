#include <cmath>
#include <iostream>
#include <memory>

#include "checks.hpp"
#include "commands.hpp"
#include "dbbkit/error.hpp"
#include "dbbkit/io/chain_io.hpp"
#include "dbbkit/io/compensation_io.hpp"
#include "dbbkit/io/json_reader.hpp"
#include "dbbkit/io/output.hpp"
#include "dbbkit/io/predict_io.hpp"
#include "dbbkit/io/result_read.hpp"
#include "dbbkit/io/text.hpp"
#include "dbbkit/user_text.hpp"
#include "grid_options.hpp"

namespace dbbkit::cli {

namespace {
struct CompensationArgs {
  std::string result, format, out, kins, tool_reference;
  std::vector<std::string> current;
  double k = 2.0;
  int record = 0;
  bool quiet = false;
  GridOptions grid;
};
}  // namespace

Runner add_compensation(CLI::App& app) {
  auto args = std::make_shared<CompensationArgs>();
  CLI::App* sub = app.add_subcommand(
      "compensation",
      "The location errors of an identify result, or a machine's corrected kinematics from a "
      "chain result, for a controller: the ISG kernel's CSV, LinuxCNC HAL settings, Siemens' "
      "swivel data record, or a table to enter by hand");
  sub->add_option("--result", args->result,
                  "Result of dbbkit identify or diagnose (--out), or a machine result of dbbkit "
                  "chain (--out)")
      ->required();
  sub->add_option("--format", args->format, "isg, linuxcnc, siemens (a machine result) or table")
      ->required()
      ->check(CLI::IsMember({"isg", "linuxcnc", "siemens", "table"}));
  sub->add_option("--record", args->record,
                  "siemens: the number n of the swivel data record ($TC_CARR..[n])")
      ->transform(integer_in(limits::kMinSwivelRecord, limits::kMaxSwivelRecord));
  CLI::Option* tool_reference = sub->add_option(
      "--tool-reference-mm", args->tool_reference,
      "siemens, a machine with a head axis: the tool adapter's reference point x,y,z with every "
      "axis at zero, in the machine file's frame (where its point_mm are given), mm");
  sub->add_option("--out", args->out, "Output file; '-' or absent: stdout");
  sub->add_option("--kins", args->kins,
                  "linuxcnc: xyzac-trt or xyzbc-trt (an A table: xyzac-trt, a B table: "
                  "xyzbc-trt by default; a C table: required)");
  sub->add_option("--current", args->current,
                  "linuxcnc: a position pin's current value, PIN=VALUE in mm (repeatable); "
                  "without it the change is written as a comment")
      ->take_all();
  sub->add_option("--k", args->k, "Coverage factor of the expanded uncertainties (default 2)")
      ->check(finite_in(limits::kMinCoverageFactor, limits::kMaxCoverageFactor));
  sub->add_flag("--quiet", args->quiet, "Nothing on the terminal but the file asked for");
  args->grid.add(sub, "The envelope the decision to enter rests on (as predict's map)");

  return [args, tool_reference]() {
    io::OutputSet outputs({{"--out", args->out.empty() ? "-" : args->out}}, {args->result});
    const std::string text = io::read_json_file(args->result);
    io::CompensationOptions o;
    o.k = args->k;
    o.linuxcnc_kins = args->kins;
    o.record = args->record;
    if (tool_reference->count() > 0)
      o.tool_reference_mm = io::parse_tool_reference(args->tool_reference, "--tool-reference-mm");
    const io::CompensationFormat f = io::compensation_format(args->format, "--format");
    {  // an option the format does not take, before its values are read
      io::CompensationOptions given = o;
      for (const std::string& c : args->current) given.current_mm.emplace(c, 0.0);
      io::check_compensation_options(f, given);
    }
    for (const std::string& c : args->current) {
      const std::size_t eq = c.find('=');
      if (eq == std::string::npos || eq == 0)
        throw InputError("--current", "", "expected PIN=VALUE, got " + quote_value(c));
      // A decimal number: no leading space, no hexadecimal or other forms strtod reads.
      const std::string number = c.substr(eq + 1);
      if (number.empty() || number.find_first_not_of("0123456789+-.eE") != std::string::npos)
        throw InputError("--current", "",
                         "the value of " + quote_value(c) + " is not a decimal number of mm");
      std::size_t used = 0;
      double v = 0;
      try {
        v = std::stod(c.substr(eq + 1), &used);
      } catch (const std::exception&) {
        used = 0;
      }
      if (used == 0 || used != c.size() - eq - 1 || !std::isfinite(v) ||
          std::abs(v) > io::kMaxCompensation_mm)
        throw InputError("--current", "",
                         "the value of " + quote_value(c) + " is not a number of mm within +-" +
                             io::fmt_num(io::kMaxCompensation_mm, 6));
      if (!o.current_mm.emplace(c.substr(0, eq), v).second)
        throw InputError("--current", "", quote_value(c.substr(0, eq)) + " is given twice");
    }
    if (io::is_chain_text(text)) {
      if (args->grid.given())
        throw InputError("--grid-radius-mm", "",
                         "a machine result: its values are judged each on its own (an envelope "
                         "over both axes is not yet judged)");
      outputs.stage("--out",
                    io::machine_compensation_text(io::chain_from_text(text, args->result), f, o));
    } else {
      const io::ResultFile r = io::result_from_text(text, args->result);
      if (args->grid.given()) o.envelope = io::grid_of(r, args->grid.request());
      outputs.stage("--out", io::compensation_text(r, f, o));
    }
    outputs.commit();
    return 0;
  };
}

}  // namespace dbbkit::cli
