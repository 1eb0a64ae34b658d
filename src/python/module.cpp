// The Python module `dbbkit`: designs, kits and readings read by the library's own
// readers (bad input raises dbbkit.InputError naming the file or key), the library's
// operations, and results whose arrays are NumPy arrays and whose `json` is the dict
// the command line writes. Long runs release the GIL; optimize and Monte Carlo look for
// Ctrl-C between choices and batches.

#include <pybind11/eigen.h>
#include <pybind11/eval.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <iomanip>
#include <limits>
#include <memory>
#include <optional>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "dbbkit/conformance.hpp"
#include "dbbkit/diagnose.hpp"
#include "dbbkit/error.hpp"
#include "dbbkit/identify.hpp"
#include "dbbkit/instrument.hpp"
#include "dbbkit/io/chain_io.hpp"
#include "dbbkit/io/compare_io.hpp"
#include "dbbkit/io/compensation_io.hpp"
#include "dbbkit/io/design_io.hpp"
#include "dbbkit/io/diagnose_io.hpp"
#include "dbbkit/io/diagnose_text.hpp"
#include "dbbkit/io/hashing.hpp"
#include "dbbkit/io/json_reader.hpp"
#include "dbbkit/io/kit_io.hpp"
#include "dbbkit/io/machine_io.hpp"
#include "dbbkit/io/measurement_io.hpp"
#include "dbbkit/io/optimize_io.hpp"
#include "dbbkit/io/predict_io.hpp"
#include "dbbkit/io/program_io.hpp"
#include "dbbkit/io/reports.hpp"
#include "dbbkit/io/result_io.hpp"
#include "dbbkit/io/result_read.hpp"
#include "dbbkit/io/setup_sheet_io.hpp"
#include "dbbkit/io/tolerances_io.hpp"
#include "dbbkit/io/trace_io.hpp"
#include "dbbkit/io/truth_io.hpp"
#include "dbbkit/io/verify_io.hpp"
#include "dbbkit/kinematics.hpp"
#include "dbbkit/limits.hpp"
#include "dbbkit/monte_carlo.hpp"
#include "dbbkit/observability.hpp"
#include "dbbkit/optimize.hpp"
#include "dbbkit/parallel.hpp"
#include "dbbkit/predict.hpp"
#include "dbbkit/program.hpp"
#include "dbbkit/setup.hpp"
#include "dbbkit/setup_sheet.hpp"
#include "dbbkit/simulate.hpp"
#include "dbbkit/trace.hpp"
#include "dbbkit/user_text.hpp"

namespace py = pybind11;

namespace dbbkit::python {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// ---------------------------------------------------------------- JSON <-> Python

py::object to_python(const nlohmann::json& j) {
  switch (j.type()) {
    case nlohmann::json::value_t::null:
      return py::none();
    case nlohmann::json::value_t::boolean:
      return py::bool_(j.get<bool>());
    case nlohmann::json::value_t::number_integer:
      return py::int_(j.get<long long>());
    case nlohmann::json::value_t::number_unsigned:
      return py::int_(j.get<unsigned long long>());
    case nlohmann::json::value_t::number_float:
      return py::float_(j.get<double>());
    case nlohmann::json::value_t::string:
      return py::str(j.get_ref<const std::string&>());
    case nlohmann::json::value_t::array: {
      py::list l;
      for (const nlohmann::json& e : j) l.append(to_python(e));
      return l;
    }
    case nlohmann::json::value_t::object: {
      py::dict d;
      for (auto it = j.begin(); it != j.end(); ++it) d[py::str(it.key())] = to_python(it.value());
      return d;
    }
    default:
      return py::none();
  }
}

std::string child(const std::string& path, const std::string& key) {
  return path.empty() ? key : path + "." + key;
}

// A str as UTF-8; one that cannot be (a lone surrogate) is an InputError at its key.
std::string text_of(py::handle h, const std::string& source, const std::string& path) {
  try {
    return h.cast<std::string>();
  } catch (py::error_already_set&) {
  } catch (const py::cast_error&) {
  }
  PyErr_Clear();
  throw InputError(source, path.empty() ? "top level" : path,
                   "text that is not valid Unicode (a lone surrogate)");
}

// A dict, list, str, number, bool or None (and NumPy scalars and arrays, through tolist())
// as the JSON the readers take; anything else, or a non-finite number, is an InputError
// at its key (`source`: "design", "kit", ...).
nlohmann::json from_python(py::handle h, const std::string& source, const std::string& path,
                           std::vector<PyObject*>& open) {
  if (h.is_none()) return nullptr;
  if (py::isinstance<py::bool_>(h)) return h.cast<bool>();
  if (py::isinstance<py::int_>(h)) {
    try {  // as the JSON parser reads a literal: unsigned when not negative
      if (h.cast<py::int_>() >= py::int_(0)) return h.cast<unsigned long long>();
      return h.cast<long long>();
    } catch (const py::cast_error&) {
      throw InputError(
          source, path,
          "the integer " + quote_value(py::str(h).cast<std::string>(), 30) + " is out of range");
    }
  }
  if (py::isinstance<py::float_>(h)) {
    const double x = h.cast<double>();
    if (!std::isfinite(x))
      throw InputError(source, path,
                       "not a finite number (" + py::repr(h).cast<std::string>() + ")");
    return x;
  }
  if (py::isinstance<py::str>(h)) return text_of(h, source, path);
  const bool container =
      py::isinstance<py::dict>(h) || py::isinstance<py::list>(h) || py::isinstance<py::tuple>(h);
  if (container) {
    // A container that holds itself would recurse for ever; one nested beyond the JSON
    // readers' depth would exhaust the stack (both end as an InputError at their key).
    if (std::find(open.begin(), open.end(), h.ptr()) != open.end())
      throw InputError(source, path.empty() ? "top level" : path,
                       "a dict or list that contains itself");
    if (open.size() >= limits::kMaxJsonDepth) {
      throw InputError(source, path.empty() ? "top level" : path,
                       "nested deeper than " + std::to_string(limits::kMaxJsonDepth) +
                           " levels (docs/formats.md, \"Limits\")");
    }
  }
  struct Open {
    std::vector<PyObject*>& open;
    bool pushed;
    ~Open() {
      if (pushed) open.pop_back();
    }
  } guard{open, container};
  if (container) open.push_back(h.ptr());
  if (py::isinstance<py::dict>(h)) {
    nlohmann::json j = nlohmann::json::object();
    for (auto item : py::reinterpret_borrow<py::dict>(h)) {
      if (!py::isinstance<py::str>(item.first)) {
        throw InputError(
            source, path,
            "a key that is not a string (" + py::repr(item.first).cast<std::string>() + ")");
      }
      const std::string key = text_of(item.first, source, path);
      j[key] = from_python(item.second, source, child(path, key), open);
    }
    return j;
  }
  if (py::isinstance<py::list>(h) || py::isinstance<py::tuple>(h)) {
    nlohmann::json j = nlohmann::json::array();
    long i = 0;
    for (py::handle e : h)
      j.push_back(from_python(e, source, path + "[" + std::to_string(i++) + "]", open));
    return j;
  }
  if (py::hasattr(h, "tolist"))
    return from_python(h.attr("tolist")(), source, path, open);  // NumPy
  throw InputError(source, path,
                   "a value of type " + py::str(h.get_type().attr("__name__")).cast<std::string>() +
                       " (expected a dict, list, str, number, bool or None)");
}

nlohmann::json from_python(py::handle h, const std::string& source, const std::string& path) {
  std::vector<PyObject*> open;
  return from_python(h, source, path, open);
}

// A path given as str, bytes or os.PathLike, as the bytes the system names it by (a str with
// the surrogates of undecodable bytes through os.fsencode); nullopt for anything else.
std::optional<std::string> as_path(py::handle h) {
  if (!py::isinstance<py::str>(h) && !py::isinstance<py::bytes>(h) && !py::hasattr(h, "__fspath__"))
    return std::nullopt;
  const py::object bytes = py::module_::import("os").attr("fsencode")(h);
  std::string path = bytes.cast<std::string>();
  // The system would read the name only up to its first NUL: another file.
  if (path.find('\0') != std::string::npos)
    throw InputError(path, "", "the path holds a NUL byte: no file has such a name");
  return path;
}

// Rows of numbers (a list of lists, or an array: its tolist()), one per column; booleans, text
// and what no float takes refused naming at[i].column.
std::vector<std::vector<double>> number_rows(py::handle at, const std::string& key,
                                             const std::vector<std::string>& columns) {
  py::object rows = py::reinterpret_borrow<py::object>(at);
  if (py::hasattr(rows, "tolist") && !py::isinstance<py::list>(rows)) rows = rows.attr("tolist")();
  const std::size_t width = columns.size();
  std::string names;
  for (const std::string& c : columns) names += (names.empty() ? "" : ", ") + c;
  const std::string expected =
      "expected rows of " + std::to_string(width) + " numbers [" + names + "] (or a CSV's path)";
  if (!py::isinstance<py::sequence>(rows) || py::isinstance<py::str>(rows) ||
      py::isinstance<py::bytes>(rows))
    throw InputError(key, "", expected);
  const py::sequence list = py::reinterpret_borrow<py::sequence>(rows);
  if (list.size() == 0) throw InputError(key, "", "no pose");
  if (list.size() > limits::kMaxPoses)
    throw InputError(key, "", "more than " + std::to_string(limits::kMaxPoses) + " poses");
  std::vector<std::vector<double>> out;
  for (std::size_t i = 0; i < list.size(); ++i) {
    const std::string where = key + "[" + std::to_string(i) + "]";
    const py::object row = list[i];
    if (!py::isinstance<py::sequence>(row) || py::isinstance<py::str>(row) ||
        py::isinstance<py::bytes>(row) || py::len(row) != width)
      throw InputError(key, where, expected);
    std::vector<double> numbers;
    for (std::size_t c = 0; c < width; ++c) {
      const py::object cell = py::reinterpret_borrow<py::sequence>(row)[c];
      const std::string at_cell = where + "." + columns[c];
      if (py::isinstance<py::bool_>(cell) || py::isinstance<py::str>(cell) ||
          py::isinstance<py::bytes>(cell) || cell.is_none())
        throw InputError(key, at_cell, "not a number");
      double x = 0;
      try {
        x = py::float_(cell).cast<double>();
      } catch (const py::error_already_set&) {
        throw InputError(key, at_cell, "not a number");
      } catch (const py::cast_error&) {
        throw InputError(key, at_cell, "not a number");
      }
      if (!std::isfinite(x)) throw InputError(key, at_cell, "not a finite number");
      numbers.push_back(x);
    }
    out.push_back(std::move(numbers));
  }
  return out;
}

// ---------------------------------------------------------------- argument checks

void check_finite_in(const char* name, double x, double lo, double hi) {
  if (!std::isfinite(x) || !(x >= lo && x <= hi)) {
    std::ostringstream m;
    m << x << " is outside [" << lo << ", " << hi << "]";
    throw InputError("argument", name, m.str());
  }
}

void check_integer_in(const char* name, long long x, long long lo, long long hi) {
  if (x < lo || x > hi) {
    throw InputError(
        "argument", name,
        std::to_string(x) + " is outside [" + std::to_string(lo) + ", " + std::to_string(hi) + "]");
  }
}

// A map's or an envelope's arguments (predict, compensation), as the command line's --grid-*:
// none without radii_mm; around a whole number (an int or what converts to one exactly, as
// numpy's), never a bool.
constexpr const char* kMachineEnvelope =
    "a machine result: its values are judged each on its own (an envelope over both axes is "
    "not yet judged)";
const io::GridKeys kGridKeys{"radii_mm", "heights_mm", "around", "angles_deg"};
std::optional<io::GridRequest> grid_request(const std::optional<std::vector<double>>& radii_mm,
                                            const std::optional<std::vector<double>>& heights_mm,
                                            py::handle around,
                                            const std::optional<std::vector<double>>& angles_deg) {
  for (const auto& [key, given] :
       {std::pair<const char*, bool>{"heights_mm", heights_mm.has_value()},
        {"around", !around.is_none()},
        {"angles_deg", angles_deg.has_value()}})
    if (given && !radii_mm)
      throw InputError(key, "", "a map's parameter: give the map's radii (radii_mm) too");
  if (!radii_mm) return std::nullopt;
  io::GridRequest request;
  request.radii_mm = *radii_mm;
  request.heights_mm = heights_mm;
  request.angles_deg = angles_deg;
  if (!around.is_none()) {
    if (py::isinstance<py::bool_>(around) || !PyIndex_Check(around.ptr()))
      throw InputError("around", "", "expected a whole number of points, 1 to 360");
    const py::int_ whole(py::reinterpret_borrow<py::object>(around));
    int overflow = 0;
    long long n = PyLong_AsLongLongAndOverflow(whole.ptr(), &overflow);
    if (overflow != 0) n = overflow > 0 ? 361 : 0;
    check_integer_in("around", n, 1, 360);
    request.around = static_cast<int>(n);
  }
  return request;
}

int thread_count(const char* name, int threads) {
  check_integer_in(name, threads, 0, kMaxThreads);
  return threads > 0 ? threads
                     : static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
}

// ---------------------------------------------------------------- Ctrl-C

// Called by the library's progress callbacks with the GIL released: on the thread that
// called into the module (the one Python delivers signals to), runs Python's signal
// handlers; a KeyboardInterrupt (or any error they raise) stops the run and is raised.
class SignalCheck {
 public:
  SignalCheck() : caller_(std::this_thread::get_id()) {}
  void operator()() const {
    if (std::this_thread::get_id() != caller_) return;
    py::gil_scoped_acquire gil;
    if (PyErr_CheckSignals() != 0) throw py::error_already_set();
  }

 private:
  std::thread::id caller_;
};

// ---------------------------------------------------------------- inputs

// An input read by the library's reader: from a path (str or os.PathLike) or from a dict
// (then `source` is its kind: "design", "kit", "truth", "tolerances").
template <typename T>
struct Input {
  T value;
  std::string source;
  bool from_file = false;
};

template <typename T>
Input<T> read_input(py::handle given, const char* kind, T (*from_file)(const std::string&),
                    T (*from_json)(const nlohmann::json&, const std::string&)) {
  if (const auto path = as_path(given)) return {from_file(*path), *path, true};
  return {from_json(from_python(given, kind, ""), kind), kind, false};
}

using PyDesign = Input<Design>;
using PyKit = Input<Kit>;

struct PyMeasurements {
  std::vector<Reading> readings;
  std::string source;
  bool from_file = false;
  bool from_text = false;  // CSV text: its errors name lines, as a file's do
  // The design they were read against: its name, where it came from, and its content (a later
  // check against another design says whose they are).
  std::string design_name, design_source, design_json;
  // The design's instrument: the file form to_csv writes (a probe's: a row per sphere).
  std::shared_ptr<const Design> design;
};

// The measurements of `design` (remembered for the check against another one).
PyMeasurements measurements_of(const PyDesign& design, std::string source) {
  PyMeasurements m;
  m.source = std::move(source);
  m.design_name = design.value.name;
  m.design_source = design.source;
  m.design_json = io::dump_json(io::design_to_json(design.value));
  m.design = std::make_shared<const Design>(design.value);
  return m;
}

PyDesign make_design(py::handle source) {
  // A dict's relative machine path is relative to the working directory.
  return read_input<Design>(
      source, "design", &io::read_design_file,
      +[](const nlohmann::json& j, const std::string& where) {
        return io::design_from_json(j, where);
      });
}

PyKit make_kit(py::handle source) {
  // A dict's relative machine path is relative to the working directory.
  return read_input<Kit>(
      source, "kit", &io::read_kit_file, +[](const nlohmann::json& j, const std::string& where) {
        return io::kit_from_json(j, where);
      });
}

// validate_readings names "line N"; readings given as arrays (not read from a file or from
// CSV text) are named by index.
void validate_rows(const Design& design, const std::vector<Reading>& readings,
                   const std::string& source, bool by_index) {
  try {
    validate_readings(design, readings, source);
  } catch (const InputError& e) {
    if (by_index && e.where().rfind("line ", 0) == 0) {
      const long line = std::stol(e.where().substr(5));
      throw InputError(source, "index " + std::to_string(line - 1), e.detail());
    }
    throw;
  }
}

// Readings checked against `d`, which may not be the design they were read against (a design
// edited since, or another one): where they do not fit it, the message says whose they are.
void validate_against(const PyDesign& d, const PyMeasurements& m) {
  try {
    validate_rows(d.value, m.readings, m.source, !m.from_file && !m.from_text);
  } catch (const InputError& e) {
    if (m.design_json.empty() || m.design_json == io::dump_json(io::design_to_json(d.value))) throw;
    throw InputError(e.source(), e.where(),
                     "these measurements were read against design " + quote_value(m.design_name) +
                         " (" + quote_value(m.design_source, 200) + "), not design " +
                         quote_value(d.value.name) + " (" + quote_value(d.source, 200) +
                         "): " + e.detail());
  }
}

// An optional column of the readings as an array, NaN where a reading has none.
template <typename T>
Eigen::VectorXd optional_column(const PyMeasurements& mm, std::optional<T> Reading::*field) {
  Eigen::VectorXd v(static_cast<Eigen::Index>(mm.readings.size()));
  for (size_t i = 0; i < mm.readings.size(); ++i) {
    const std::optional<T>& x = mm.readings[i].*field;
    v(static_cast<Eigen::Index>(i)) = x ? static_cast<double>(*x) : kNaN;
  }
  return v;
}

PyMeasurements measurements_from_arrays(const PyDesign& d, py::object installation_seq,
                                        py::object angle_deg_seq, py::object reading_um_seq,
                                        py::object time_s_seq, py::object sweep_seq,
                                        py::object repeat_seq) {
  // Counted before anything is converted: more readings than a measurement file may hold
  // are refused before they cost memory.
  for (const auto& [name, seq] :
       {std::pair<const char*, py::object*>{"installation", &installation_seq},
        {"angle_deg", &angle_deg_seq},
        {"reading_um", &reading_um_seq},
        {"time_s", &time_s_seq},
        {"sweep", &sweep_seq},
        {"repeat", &repeat_seq}}) {
    if (seq->is_none()) continue;
    if (!py::hasattr(*seq, "__len__"))
      throw InputError("measurements", name, "expected a list or an array (one value per reading)");
    // NumPy: one value per reading, real (a complex array would be made real, a 2-D one flat).
    if (py::hasattr(*seq, "ndim") && seq->attr("ndim").cast<long>() != 1)
      throw InputError("measurements", name,
                       "expected a one-dimensional array (one value per reading)");
    if (py::hasattr(*seq, "dtype") && seq->attr("dtype").attr("kind").cast<std::string>() == "c")
      throw InputError("measurements", name, "complex numbers: expected real ones");
    if (py::len(*seq) > limits::kMaxReadings) {
      throw InputError("measurements", name,
                       std::to_string(py::len(*seq)) + " values: more than the " +
                           std::to_string(limits::kMaxReadings) +
                           " readings one measurement may hold (docs/formats.md, \"Limits\")");
    }
  }
  if (installation_seq.is_none() || angle_deg_seq.is_none() || reading_um_seq.is_none())
    throw InputError("measurements", "", "installation, angle_deg and reading_um are required");
  // A value of the wrong type is a TypeError, as pybind11's own argument conversion says.
  auto as = [](const py::object& seq, const char* name, const char* what) {
    return [&seq, name, what](auto tag) {
      try {
        return seq.cast<decltype(tag)>();
      } catch (const py::cast_error&) {
        throw py::type_error(std::string("from_arrays: ") + name + " must be " + what);
      }
    };
  };
  const auto installation =
      as(installation_seq, "installation", "a list of str")(std::vector<std::string>{});
  const auto angle_deg =
      as(angle_deg_seq, "angle_deg", "a list or array of numbers")(std::vector<double>{});
  const auto reading_um =
      as(reading_um_seq, "reading_um", "a list or array of numbers")(std::vector<double>{});
  const auto time_s = as(time_s_seq, "time_s", "a list or array of numbers, or None")(
      std::optional<std::vector<double>>{});
  const auto sweep = as(sweep_seq, "sweep", "a list of 'cw', 'ccw' or None, or None")(
      std::optional<std::vector<std::optional<std::string>>>{});
  const auto repeat =
      as(repeat_seq, "repeat", "a list of int, or None")(std::optional<std::vector<int>>{});
  const size_t n = installation.size();
  auto same_length = [n](const char* name, size_t m) {
    if (m != n) {
      throw InputError("measurements", name,
                       std::to_string(m) + " values for " + std::to_string(n) +
                           " installations (one per reading)");
    }
  };
  same_length("angle_deg", angle_deg.size());
  same_length("reading_um", reading_um.size());
  if (time_s) same_length("time_s", time_s->size());
  if (sweep) same_length("sweep", sweep->size());
  if (repeat) same_length("repeat", repeat->size());
  PyMeasurements m = measurements_of(d, "measurements");
  m.readings.resize(n);
  for (size_t i = 0; i < n; ++i) {
    Reading& r = m.readings[i];
    r.installation = installation[i];
    r.angle_deg = angle_deg[i];
    r.reading_um = reading_um[i];
    r.line = static_cast<int>(i + 1);
    if (time_s && !std::isnan((*time_s)[i])) r.time_s = (*time_s)[i];
    if (sweep && (*sweep)[i]) {
      const std::string& s = *(*sweep)[i];
      if (s == "cw") {
        r.sweep = Sweep::kCW;
      } else if (s == "ccw") {
        r.sweep = Sweep::kCCW;
      } else {
        throw InputError("measurements", "sweep[" + std::to_string(i) + "]",
                         quote_value(s) + " (expected cw, ccw or None)");
      }
    }
    if (repeat) r.repeat = (*repeat)[i];
  }
  validate_rows(d.value, m.readings, m.source, true);
  return m;
}

// Readings from a CSV file or text, checked against the design.
PyMeasurements measurements_from_file(const std::string& path, const PyDesign& d) {
  PyMeasurements m = measurements_of(d, path);
  m.readings = io::read_measurement_file(path, d.value);
  m.from_file = true;
  return m;
}

// ---------------------------------------------------------------- arrays

// (stations, 6): values or std, NaN where the error is not determined.
Eigen::MatrixXd errors_array(const std::vector<ErrorsAtAngle>& errors, bool values) {
  Eigen::MatrixXd a(static_cast<Eigen::Index>(errors.size()), 6);
  for (size_t s = 0; s < errors.size(); ++s) {
    for (int k = 0; k < 6; ++k) {
      const Determined& d = errors[s].errors[k];
      a(static_cast<Eigen::Index>(s), k) = d.determined ? (values ? d.value : d.std) : kNaN;
    }
  }
  return a;
}

Eigen::VectorXd angles_array(const std::vector<ErrorsAtAngle>& errors) {
  Eigen::VectorXd a(static_cast<Eigen::Index>(errors.size()));
  for (size_t s = 0; s < errors.size(); ++s) a(static_cast<Eigen::Index>(s)) = errors[s].angle_deg;
  return a;
}

py::array_t<bool> determined_array(const std::vector<ErrorsAtAngle>& errors) {
  py::array_t<bool> a({static_cast<py::ssize_t>(errors.size()), py::ssize_t{6}});
  auto m = a.mutable_unchecked<2>();
  for (size_t s = 0; s < errors.size(); ++s) {
    for (int k = 0; k < 6; ++k) m(static_cast<py::ssize_t>(s), k) = errors[s].errors[k].determined;
  }
  return a;
}

std::string iframe(const std::string& html) {
  std::string escaped;
  for (char c : html) {
    if (c == '&') {
      escaped += "&amp;";
    } else if (c == '"') {
      escaped += "&quot;";
    } else {
      escaped += c;
    }
  }
  return "<iframe style=\"width: 100%; height: 900px; border: 1px solid #ccc\" srcdoc=\"" +
         escaped + "\"></iframe>";
}

io::ReportFormat report_format(const std::string& format) {
  if (format == "html") return io::ReportFormat::kHtml;
  if (format == "markdown") return io::ReportFormat::kMarkdown;
  throw InputError("argument", "format", quote_value(format) + " (expected html or markdown)");
}

// ---------------------------------------------------------------- Monte Carlo

MonteCarloOptions mc_options(std::uint64_t seed, int threads, long max_trials, long batch,
                             int digits) {
  check_integer_in("mc_max_trials", max_trials, limits::kMinMonteCarloTrials,
                   limits::kMaxMonteCarloTrials);
  check_integer_in("mc_batch", batch, limits::kMinMonteCarloTrials, limits::kMaxMonteCarloBatch);
  check_integer_in("mc_digits", digits, limits::kMinSignificantDigits,
                   limits::kMaxSignificantDigits);
  MonteCarloOptions o;
  o.seed = seed;
  o.threads = thread_count("mc_threads", threads);
  o.max_trials = max_trials;
  o.batch_trials = batch;
  o.significant_digits = digits;
  return o;
}

struct PyMonteCarlo {
  MonteCarloResult mc;
};

// ---------------------------------------------------------------- results

// The files a result was computed from (a report hashes them); inputs given as dicts have none.
template <class... Inputs>
std::vector<std::string> files_of(const Inputs&... inputs) {
  std::vector<std::string> f;
  ((inputs.from_file ? f.push_back(inputs.source) : void()), ...);
  return f;
}

py::list warnings_list(const std::vector<Warning>& warnings) {
  py::list out;
  for (const Warning& w : warnings) {
    py::dict d;
    d["kind"] = w.kind;
    d["text"] = w.text;
    out.append(d);
  }
  return out;
}

// Measurements.from_trace: the readings of every installation's trace, and the dwells found.
py::tuple measurements_from_trace(const PyDesign& design, const py::dict& traces, double dwell_s,
                                  const std::string& sweeps, double min_share,
                                  std::optional<std::string> columns,
                                  std::optional<std::string> unit,
                                  std::optional<double> sample_rate_hz,
                                  const std::map<std::string, double>& start_s) {
  check_finite_in("dwell_s", dwell_s, limits::kMinTraceDwell_s, limits::kMaxDwell_s);
  for (const auto& [id, s] : start_s) {
    if (!traces.contains(py::str(id)))
      throw InputError("start_s", quote_value(id), "no trace of this installation");
    check_finite_in("start_s", s, -limits::kMaxTraceStart_s, limits::kMaxTraceStart_s);
  }
  check_finite_in("min_share", min_share, limits::kMinDwellShare, 1);
  const std::vector<Sweep> sw = sweeps_by_name(sweeps, "sweeps");
  io::TraceFormat format;
  if (columns) io::parse_trace_columns(*columns, format);
  if (unit && *unit != "um" && *unit != "mm")
    throw InputError("argument", "unit", quote_value(*unit) + " is not um or mm");
  if (unit && format.reading_column.empty())
    throw InputError("argument", "unit", "unit goes with columns='reading=NAME'");
  if (unit) format.unit = *unit;
  format.sample_rate_hz = sample_rate_hz;
  // A trace's column from Python: a 1-D array of numbers, within the samples a trace may hold
  // (its length checked before anything is copied).
  auto column = [](py::handle h, const std::string& what) {
    if (py::hasattr(h, "__len__") && py::len(h) > io::kMaxTraceSamples) {
      throw InputError("argument", what,
                       std::to_string(py::len(h)) + " samples, more than the " +
                           std::to_string(io::kMaxTraceSamples) +
                           " one trace may hold (docs/formats.md, \"Limits\")");
    }
    const auto a = py::array_t<double, py::array::forcecast>::ensure(h);
    if (!a) throw InputError("argument", what, "not an array of numbers");
    if (a.ndim() != 1) {
      std::string shape;
      for (py::ssize_t k = 0; k < a.ndim(); ++k)
        shape += (k ? ", " : "") + std::to_string(a.shape(k));
      throw InputError("argument", what,
                       "a 1-D array of numbers, got one of shape (" + shape + ")");
    }
    if (static_cast<std::size_t>(a.size()) > io::kMaxTraceSamples) {
      throw InputError("argument", what,
                       std::to_string(a.size()) + " samples, more than the " +
                           std::to_string(io::kMaxTraceSamples) +
                           " one trace may hold (docs/formats.md, \"Limits\")");
    }
    const auto v = a.unchecked<1>();
    std::vector<double> out(static_cast<std::size_t>(a.size()));
    for (py::ssize_t i = 0; i < a.size(); ++i) out[static_cast<std::size_t>(i)] = v(i);
    return out;
  };
  DwellOptions options;
  options.dwell_s = dwell_s;
  options.min_share = min_share;
  PyMeasurements mm = measurements_of(design, "traces");
  py::dict found;
  std::vector<Warning> warnings;
  std::vector<std::pair<std::string, std::string>> paths;  // installation, file
  // Every id before any trace is read: an id that is none is the argument's fault, not a file's.
  for (const auto& [key, value] : traces) {
    if (!py::isinstance<py::str>(key))
      throw InputError("argument", "traces", "keys are installation ids (str)");
    check_trace_installation(design.value, key.cast<std::string>());
  }
  for (const auto& [key, value] : traces) {
    const std::string id = key.cast<std::string>();
    Trace trace;
    std::string source = "traces[" + quote_value(id) + "]";
    if (const auto path = as_path(value)) {
      for (const auto& [other, other_path] : paths) {
        std::error_code ec;
        if (other_path == *path || std::filesystem::equivalent(other_path, *path, ec)) {
          throw InputError("argument", "traces",
                           "one file " + quote_value(*path) + " given for installations " +
                               quote_value(other) + " and " + quote_value(id) +
                               ": each installation is a recording of its own");
        }
      }
      paths.emplace_back(id, *path);
      trace = io::read_trace_file(*path, format);
      source = *path;
    } else if (py::isinstance<py::tuple>(value) && py::len(value) == 2) {
      const auto t = value.cast<py::tuple>();
      trace.time_s = column(t[0], source + "[0] (time_s)");
      trace.reading_um = column(t[1], source + "[1] (reading_um)");
      if (trace.time_s.size() != trace.reading_um.size()) {
        throw InputError("argument", source,
                         "time_s has " + std::to_string(trace.time_s.size()) +
                             " values, reading_um " + std::to_string(trace.reading_um.size()) +
                             ": one of each per sample");
      }
    } else {
      throw InputError("argument", "traces",
                       "each value is a trace file path or a (time_s, reading_um) pair of arrays");
    }
    TraceReadings r;
    {
      py::gil_scoped_release release;
      r = readings_from_trace(design.value, id, trace, sw, options, source);
    }
    mm.readings.insert(mm.readings.end(), r.readings.begin(), r.readings.end());
    warnings.insert(warnings.end(), r.warnings.begin(), r.warnings.end());
    const std::size_t n = r.search.plateaus.size();
    Eigen::VectorXd a(n), b(n), c(n), e(n), level(n), scatter(n), count(n);
    for (std::size_t k = 0; k < n; ++k) {
      const Plateau& p = r.search.plateaus[k];
      const auto i = static_cast<Eigen::Index>(k);
      a(i) = p.start_s, b(i) = p.end_s, c(i) = p.settled_start_s, e(i) = p.settled_end_s;
      level(i) = p.level_um, scatter(i) = p.std_um, count(i) = static_cast<double>(p.samples);
    }
    py::dict d;
    d["start_s"] = a;
    d["end_s"] = b;
    d["settled_start_s"] = c;
    d["settled_end_s"] = e;
    d["level_um"] = level;
    d["std_um"] = scatter;
    d["samples"] = count;
    d["noise_um"] = r.search.noise_um;
    found[py::str(id)] = d;
  }
  if (auto w = put_on_test_clock(design.value, mm.readings, start_s, "start_s"))
    warnings.push_back(*w);
  validate_readings(design.value, mm.readings, "traces");
  py::dict out;
  out["dwells"] = found;
  out["warnings"] = warnings_list(warnings);
  return py::make_tuple(mm, out);
}

struct PyEvaluateResult {
  std::shared_ptr<const PyDesign> design;
  Evaluation ev;
  std::vector<CandidateStatus> effects;
  std::optional<MonteCarloResult> mc;
  Expansion expansion;  // of the coverage asked for
  nlohmann::json json;
  std::string report(const std::string& format) const {
    const io::RunContext run{"dbbkit.evaluate (Python)", files_of(*design)};
    return io::evaluate_report(report_format(format), run, design->value, ev, {}, {},
                               mc ? &*mc : nullptr, expansion);
  }
};

struct PyIdentifyResult {
  std::shared_ptr<const PyDesign> design;
  std::shared_ptr<const PyMeasurements> data;
  std::shared_ptr<const IdentifyResult> held;
  const IdentifyResult& result() const { return *held; }
  std::optional<MonteCarloResult> mc;
  std::optional<ConformanceReport> conformance;
  std::vector<std::string> tolerance_files;  // the tolerance file, when read from one
  nlohmann::json json;
  std::string report(const std::string& format) const {
    std::vector<std::string> files = files_of(*design, *data);
    files.insert(files.end(), tolerance_files.begin(), tolerance_files.end());
    const io::RunContext run{"dbbkit.identify (Python)", files};
    return io::identify_report(report_format(format), run, design->value, data->readings, result(),
                               mc ? &*mc : nullptr, conformance ? &*conformance : nullptr);
  }
  // (stations, 6) of the budget's U and its k, NaN where not determined.
  Eigen::MatrixXd budget_array(bool expanded) const {
    Eigen::MatrixXd a =
        Eigen::MatrixXd::Constant(static_cast<Eigen::Index>(result().errors.size()), 6, kNaN);
    for (const ValueBudget& v : result().budget.values)
      a(v.station, v.error) = expanded ? v.U : v.k;
    return a;
  }
  // (6 x stations, 6 x stations): row 6 s + k is error k at station s; NaN where not determined.
  Eigen::MatrixXd covariance() const {
    const Eigen::MatrixXd c = budget_covariance(design->value, result());
    const Eigen::Index n = 6 * static_cast<Eigen::Index>(result().errors.size());
    Eigen::MatrixXd full = Eigen::MatrixXd::Constant(n, n, kNaN);
    const std::vector<ValueBudget>& v = result().budget.values;
    for (size_t a = 0; a < v.size(); ++a) {
      for (size_t b = 0; b < v.size(); ++b) {
        full(6 * v[a].station + v[a].error, 6 * v[b].station + v[b].error) =
            c(static_cast<Eigen::Index>(a), static_cast<Eigen::Index>(b));
      }
    }
    return full;
  }
};

struct PyDiagnoseResult {
  std::shared_ptr<const PyDesign> design;
  std::shared_ptr<const PyMeasurements> data;
  DiagnoseResult result;
  std::optional<ConformanceReport> conformance;
  std::vector<std::string> tolerance_files;  // the tolerance file, when read from one
  nlohmann::json json;
  // (6 x stations, 6 x stations): the final model's covariance of the errors after (row 6 s + k:
  // error k at station s); NaN where not determined. The attributions' share is in std_after
  // alone (a change, not a correlation): this diagonal leaves it out.
  Eigen::MatrixXd covariance_after() const {
    const Parameterisation param(design->value);
    const Estimate& est = result.after;
    const Eigen::Index n = 6 * static_cast<Eigen::Index>(result.errors_after.size());
    Eigen::MatrixXd full = Eigen::MatrixXd::Constant(n, n, kNaN);
    std::vector<Estimate::Function> f;
    std::vector<Eigen::Index> row;
    for (std::size_t i = 0; i < result.errors_after.size(); ++i) {
      const ErrorsAtAngle& ea = result.errors_after[i];
      const Eigen::SparseMatrix<double> E = error_functions(param, ea.station, est.n_unknowns);
      for (int k = 0; k < 6; ++k) {
        if (!ea.errors[static_cast<std::size_t>(k)].determined) continue;
        f.push_back(Estimate::Function(E.col(k)));
        row.push_back(6 * static_cast<Eigen::Index>(i) + k);
      }
    }
    // The functions as the columns of one sparse matrix F: F' covariance F (+ the low-rank
    // term's (K'F)' S (K'F)), formed once.
    const Eigen::Index m = static_cast<Eigen::Index>(f.size());
    std::vector<Eigen::Triplet<double>> entries;
    for (Eigen::Index a = 0; a < m; ++a)
      for (Estimate::Function::InnerIterator it(f[static_cast<std::size_t>(a)]); it; ++it)
        entries.emplace_back(it.index(), a, it.value());
    Eigen::SparseMatrix<double> F(est.covariance.rows(), m);
    F.setFromTriplets(entries.begin(), entries.end());
    Eigen::MatrixXd C = Eigen::MatrixXd(F.transpose() * (est.covariance * F));
    if (est.covariance_K.cols() > 0 && m > 0) {
      Eigen::MatrixXd KF(est.covariance_K.cols(), m);
      for (Eigen::Index a = 0; a < m; ++a)
        KF.col(a) = est.low_rank_coordinates(f[static_cast<std::size_t>(a)]);
      C += KF.transpose() * est.covariance_S * KF;
    }
    for (Eigen::Index a = 0; a < m; ++a)
      for (Eigen::Index b = 0; b < m; ++b)
        full(row[static_cast<std::size_t>(a)], row[static_cast<std::size_t>(b)]) = C(a, b);
    return full;
  }
  std::string report(const std::string& format) const {
    std::vector<std::string> files = files_of(*design, *data);
    files.insert(files.end(), tolerance_files.begin(), tolerance_files.end());
    return io::diagnose_report(
        report_format(format), io::RunContext{"dbbkit.diagnose (Python)", files}, design->value,
        data->readings, result, a_priori_expansion(), conformance ? &*conformance : nullptr);
  }
};

struct PyOptimizeResult {
  std::shared_ptr<const PyKit> kit;
  OptimizeResult result;
  std::optional<Reference> reference;
  double seconds = 0;
  nlohmann::json json;
  std::string report(const std::string& format) const {
    std::vector<std::string> f = files_of(*kit);
    if (reference) f.push_back(reference->file);
    return io::optimize_report(report_format(format), io::RunContext{"dbbkit.optimize (Python)", f},
                               kit->value, result, reference, seconds, a_priori_expansion());
  }
};

// ---------------------------------------------------------------- ISO 230 quantities

// The ISO 230 quantities of a result, typed (the JSON's "iso230" as objects and arrays).
struct PyIso230 {
  IsoResult iso;
};

py::object optional_float(const Determined& d, bool std) {
  if (!d.determined) return py::none();
  return py::float_(std ? d.std : d.value);
}

Eigen::MatrixXd iso_components(const IsoResult& iso, bool std) {
  Eigen::MatrixXd a =
      Eigen::MatrixXd::Constant(static_cast<Eigen::Index>(iso.components.size()), 6, kNaN);
  for (std::size_t i = 0; i < iso.components.size(); ++i) {
    for (int k = 0; k < 6; ++k) {
      const Determined& d = iso.components[i].motions[static_cast<std::size_t>(k)];
      if (d.determined) a(static_cast<Eigen::Index>(i), k) = std ? d.std : d.value;
    }
  }
  return a;
}

// ---------------------------------------------------------------- program and set-up sheet

// The options of `dbbkit program` and `setup-sheet`, checked as the command line checks them.
ProgramOptions py_program_options(const PyDesign& d, const std::string& sweeps, double dwell_s,
                                  double feed_mm_min, double path_tolerance_mm, int tool,
                                  std::optional<double> clearance_z_mm, double clearance_margin_mm,
                                  bool air_run, const std::string& orient_code,
                                  const std::optional<std::string>& tcpm) {
  // The command line's ranges (program_options.hpp), then the library's own checks.
  check_finite_in("dwell_s", dwell_s, limits::kMinDwell_s, limits::kMaxDwell_s);
  check_finite_in("feed_mm_min", feed_mm_min, limits::kMinFeed_mm_per_min,
                  limits::kMaxFeed_mm_per_min);
  check_finite_in("path_tolerance_mm", path_tolerance_mm, limits::kMinPathTolerance_mm,
                  limits::kMaxPathTolerance_mm);
  check_integer_in("tool", tool, limits::kMinToolNumber, limits::kMaxToolNumber);
  if (clearance_z_mm)
    check_finite_in("clearance_z_mm", *clearance_z_mm, -limits::kMaxLength_mm,
                    limits::kMaxLength_mm);
  check_finite_in("clearance_margin_mm", clearance_margin_mm, limits::kMinClearanceMargin_mm,
                  limits::kMaxClearanceMargin_mm);
  ProgramOptions o;
  const auto named = program_sweeps_named(sweeps);
  if (!named)
    throw InputError("argument", "sweeps", quote_value(sweeps) + " (expected ccw, cw or both)");
  o.sweeps = *named;
  o.dwell_s = dwell_s;
  o.feed_mm_per_min = feed_mm_min;
  o.path_tolerance_mm = path_tolerance_mm;
  o.tool_number = tool;
  o.clearance_z_mm = clearance_z_mm;
  o.clearance_margin_mm = clearance_margin_mm;
  o.air_run = air_run;
  o.orient_code = orient_code == "none" ? std::string() : orient_code;
  if (tcpm && *tcpm != "on" && *tcpm != "off")
    throw InputError("argument", "tcpm", quote_value(*tcpm) + " (expected 'on' or 'off')");
  if (d.value.machine && !tcpm)
    throw InputError("argument", "tcpm",
                     "the design names machine " + quote_value(d.value.machine->machine->name) +
                         ": give tcpm='on' (the controller's kinematics moves the linear axes) "
                         "or tcpm='off' (the positions come from the machine file's axis points)");
  o.tcpm = tcpm && *tcpm == "on";
  validate_program_options(o, "argument");
  return o;
}

struct PySetupSheet {
  std::shared_ptr<const PyDesign> design;
  std::shared_ptr<const PyKit> kit;  // may be null
  SetupSheet sheet;
  std::string report(const std::string& format) const {
    std::vector<std::string> files = files_of(*design);
    if (kit && kit->from_file) files.push_back(kit->source);
    return io::setup_sheet_report(report_format(format),
                                  io::RunContext{"dbbkit.setup_sheet (Python)", files}, sheet,
                                  kit ? kit->source : std::string());
  }
};

SetupSheet sheet_of(const PyDesign& d, const PyKit* kit, std::optional<double> resolution_mm,
                    const ProgramOptions& options) {
  if (resolution_mm)
    check_finite_in("resolution_mm", *resolution_mm, limits::kMinResolution_mm,
                    limits::kMaxResolution_mm);
  else if (kit)
    resolution_mm = kit->value.resolution_mm;
  if (kit && kit->value.axis.letter() != d.value.axis.letter())
    throw InputError(kit->source, "axis",
                     "the kit is for axis " + kit->value.axis.label() + ", the design for " +
                         d.value.axis.label());
  try {
    return make_setup_sheet(d.value, options, resolution_mm, kit ? &kit->value : nullptr);
  } catch (const InputError& e) {
    throw e.source() == "design" ? e.with_source(d.source) : e;
  }
}

std::string run_program(const PyDesign& d, const std::string& dialect, std::optional<PyKit> kit,
                        std::optional<int> program_number, const std::string& sweeps,
                        double dwell_s, double feed_mm_min, double path_tolerance_mm, int tool,
                        std::optional<double> clearance_z_mm, double clearance_margin_mm,
                        bool air_run, const std::string& orient_code,
                        const std::optional<std::string>& tcpm) {
  const std::optional<io::Dialect> named_dialect = io::dialect_named(dialect);
  if (!named_dialect)
    throw InputError("argument", "dialect",
                     quote_value(dialect) + " (expected iso, heidenhain or sinumerik)");
  if (program_number) {
    if (const auto refusal = io::program_number_refusal(*named_dialect))
      throw InputError("argument", "program_number", *refusal);
    check_integer_in("program_number", *program_number, limits::kMinProgramNumber,
                     limits::kMaxProgramNumber);
  }
  const ProgramOptions o =
      py_program_options(d, sweeps, dwell_s, feed_mm_min, path_tolerance_mm, tool, clearance_z_mm,
                         clearance_margin_mm, air_run, orient_code, tcpm);
  MeasurementProgram program;
  if (kit) {
    const SetupSheet sheet = sheet_of(d, &*kit, std::nullopt, o);
    if (!sheet.fits_kit())
      throw InputError(kit->source, "travel",
                       "the design does not fit the kit: " + io::setup_sheet_summary(sheet));
    program = sheet.program;
  } else {
    try {
      program = measurement_program(d.value, o);
    } catch (const InputError& e) {
      throw e.source() == "design" ? e.with_source(d.source) : e;
    }
  }
  return io::program_text(d.value, program, *named_dialect, program_number.value_or(1));
}

PySetupSheet run_setup_sheet(const PyDesign& d, std::optional<PyKit> kit,
                             std::optional<double> resolution_mm, const std::string& sweeps,
                             double dwell_s, double feed_mm_min, double path_tolerance_mm, int tool,
                             std::optional<double> clearance_z_mm, double clearance_margin_mm,
                             bool air_run, const std::string& orient_code,
                             const std::optional<std::string>& tcpm) {
  const ProgramOptions o =
      py_program_options(d, sweeps, dwell_s, feed_mm_min, path_tolerance_mm, tool, clearance_z_mm,
                         clearance_margin_mm, air_run, orient_code, tcpm);
  PySetupSheet r;
  r.design = std::make_shared<const PyDesign>(d);
  if (kit) r.kit = std::make_shared<const PyKit>(*kit);
  r.sheet = sheet_of(d, kit ? &*kit : nullptr, resolution_mm, o);
  return r;
}

// ---------------------------------------------------------------- operations

PyEvaluateResult run_evaluate(const PyDesign& d, std::optional<double> reference_length_mm,
                              bool monte_carlo, double coverage, std::uint64_t mc_seed,
                              int mc_threads, long mc_max_trials, long mc_batch, int mc_digits) {
  if (reference_length_mm)
    check_finite_in("reference_length_mm", *reference_length_mm, limits::kMinReferenceLength_mm,
                    limits::kMaxLength_mm);
  check_finite_in("coverage", coverage, limits::kMinCoverage, limits::kMaxCoverage);
  MonteCarloOptions mc = mc_options(mc_seed, mc_threads, mc_max_trials, mc_batch, mc_digits);
  const std::optional<double> ref =
      reference_length_mm ? reference_length_mm : d.value.reference_length_mm;
  if (!ref || !(*ref > 0)) {
    throw InputError(d.source, "reference_length_mm",
                     "needed to express angular uncertainty in um (or give reference_length_mm=)");
  }
  PyEvaluateResult r;
  r.design = std::make_shared<const PyDesign>(d);
  r.expansion = a_priori_expansion(coverage);
  const SignalCheck check;
  mc.progress = [&check](long) { check(); };
  {
    py::gil_scoped_release release;
    DesignAssessment assessed = assess_design(d.value, *ref);
    r.ev = std::move(assessed.evaluation);
    r.effects = std::move(assessed.effects);
    if (monte_carlo) r.mc = monte_carlo_a_priori(d.value, coverage, mc);
  }
  r.json = io::evaluate_to_json(d.value, r.ev, d.source, r.mc ? &*r.mc : nullptr);
  r.json["effects"] = io::effects_to_json(r.effects);
  return r;
}

// A tolerance argument (None, a path or a dict), read and checked against the design's axis
// before the work.
struct PyTolerances {
  std::vector<Tolerance> tolerances;
  std::string source;
  std::vector<std::string> files;  // the file, when read from one
};
PyTolerances read_tolerances(const PyDesign& d, const py::object& tolerances) {
  PyTolerances t;
  if (tolerances.is_none()) return t;
  Input<std::vector<Tolerance>> in = read_input<std::vector<Tolerance>>(
      tolerances, "tolerances", &io::read_tolerances_file, &io::tolerances_from_json);
  t.tolerances = std::move(in.value);
  t.source = in.source;
  check_tolerances(d.value.axis, t.tolerances, t.source);
  if (in.from_file) t.files.push_back(in.source);
  return t;
}

PyIdentifyResult run_identify(const PyDesign& d, const PyMeasurements& m, bool type_a,
                              double coverage, py::object tolerances, bool monte_carlo,
                              std::uint64_t mc_seed, int mc_threads, long mc_max_trials,
                              long mc_batch, int mc_digits, const py::object& effects,
                              bool type_a_readings) {
  check_finite_in("coverage", coverage, limits::kMinCoverage, limits::kMaxCoverage);
  if (type_a_readings && monte_carlo)
    throw InputError("type_a_readings", "",
                     "Monte Carlo draws the declared noise only: leave out monte_carlo");
  // A comma-separated string of labels or a list of them, as diagnose names them.
  std::vector<EffectCandidate> fitted;
  if (py::isinstance<py::str>(effects)) {
    fitted = effects_from_list(d.value, effects.cast<std::string>(), "effects");
  } else if (!effects.is_none()) {
    if (!py::isinstance<py::sequence>(effects))
      throw InputError("argument", "effects", "expected None, a string or a list of strings");
    for (const py::handle h : effects) {
      if (!py::isinstance<py::str>(h))
        throw InputError("argument", "effects", "expected a list of strings (effect labels)");
      fitted.push_back(effect_from_label(d.value, h.cast<std::string>(), "effects",
                                         "effect " + std::to_string(fitted.size() + 1)));
    }
  }
  MonteCarloOptions mc = mc_options(mc_seed, mc_threads, mc_max_trials, mc_batch, mc_digits);
  validate_against(d, m);
  PyIdentifyResult r;
  const PyTolerances tol = read_tolerances(d, tolerances);
  const std::vector<Tolerance>& tols = tol.tolerances;
  const std::string& tol_source = tol.source;
  r.tolerance_files = tol.files;
  r.design = std::make_shared<const PyDesign>(d);
  r.data = std::make_shared<const PyMeasurements>(m);
  const SignalCheck check;
  mc.progress = [&check](long) { check(); };
  {
    py::gil_scoped_release release;
    IdentifyOptions options;
    options.effects = fitted;
    options.effects_source = "effects";
    options.budget.type_a = type_a;
    options.budget.coverage_probability = coverage;
    if (type_a_readings)
      options.budget = with_reading_type_a(options.budget, m.readings, m.source, "type_a_readings");
    options.iso_motion.seed = mc_seed;
    r.held = std::make_shared<const IdentifyResult>(identify(d.value, m.readings, options));
    if (monte_carlo) r.mc = dbbkit::monte_carlo(d.value, r.result(), mc);
    if (!tols.empty()) {
      r.conformance =
          decide_conformance(d.value, r.result(), tols, tol_source, r.mc ? &*r.mc : nullptr);
    }
  }
  r.json = io::identify_to_json(d.value, m.readings, r.result(), {d.source, m.source},
                                r.mc ? &*r.mc : nullptr);
  if (r.conformance) r.json["conformance"] = io::conformance_to_json(*r.conformance, tol_source);
  return r;
}

PyDiagnoseResult run_diagnose(const PyDesign& d, const PyMeasurements& m, double level,
                              int max_effects, bool exclude_gross, const py::object& tolerances) {
  check_finite_in("level", level, limits::kMinLevel, limits::kMaxLevel);
  check_integer_in("max_effects", max_effects, 0, limits::kMaxEffects);
  validate_against(d, m);
  PyDiagnoseResult r;
  const PyTolerances tol = read_tolerances(d, tolerances);
  r.tolerance_files = tol.files;
  r.design = std::make_shared<const PyDesign>(d);
  r.data = std::make_shared<const PyMeasurements>(m);
  {
    py::gil_scoped_release release;
    DiagnoseOptions options;
    options.level = level;
    options.max_effects = max_effects;
    options.exclude_gross = exclude_gross;
    r.result = dbbkit::diagnose(d.value, m.readings, options);
    if (!tol.tolerances.empty())
      r.conformance = decide_conformance(d.value, r.result, tol.tolerances, tol.source);
  }
  r.json = io::diagnose_to_json(d.value, m.readings, r.result, {d.source, m.source});
  if (r.conformance) r.json["conformance"] = io::conformance_to_json(*r.conformance, tol.source);
  return r;
}

PyOptimizeResult run_optimize(const PyKit& k, std::optional<std::string> criterion, int threads,
                              bool require_setup_detection, std::optional<PyDesign> reference) {
  Kit kit = k.value;
  const Criterion c = search_criterion(kit, criterion, require_setup_detection, k.source,
                                       "criterion", "require_setup_detection");
  OptimizeOptions options;
  options.criterion = c;
  options.threads = thread_count("threads", threads);
  const SignalCheck check;
  options.progress = [&check](int, int, const Candidate*) { check(); };
  PyOptimizeResult r;
  r.kit = std::make_shared<const PyKit>(PyKit{kit, k.source, k.from_file});
  {
    py::gil_scoped_release release;
    if (reference) r.reference = make_reference(kit, reference->value, reference->source);
    const auto start = std::chrono::steady_clock::now();
    r.result = optimize_kit(kit, options);
    r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  }
  r.json = io::optimize_to_json(kit, r.result, k.source, r.seconds, r.reference);
  return r;
}

PyMeasurements run_simulate(const PyDesign& d, py::handle truth,
                            std::optional<std::uint64_t> seed) {
  const Input<Truth> in =
      read_input<Truth>(truth, "truth", &io::read_truth_file, &io::truth_from_json);
  const Truth& t = in.value;
  const std::string& source = in.source;
  validate_truth(t, d.value, source);
  const std::optional<std::uint64_t> s = seed ? seed : t.seed;
  if (!s && !t.noiseless)
    throw InputError(source, "seed", "no seed: give seed= or \"seed\" in the truth");
  PyMeasurements m = measurements_of(d, "simulated");
  {
    py::gil_scoped_release release;
    m.readings = dbbkit::simulate(d.value, t, s.value_or(0));
  }
  return m;
}

// ---------------------------------------------------------------- Monte Carlo arrays

py::dict monte_carlo_arrays(const MonteCarloResult& mc) {
  const Eigen::Index n = static_cast<Eigen::Index>(mc.values.size());
  Eigen::VectorXd angle(n), mean(n), std(n), low(n), high(n), value(n), u(n), U(n);
  Eigen::VectorXi station(n), error(n);
  py::array_t<bool> validated(n);
  auto vm = validated.mutable_unchecked<1>();
  for (Eigen::Index i = 0; i < n; ++i) {
    const MonteCarloValue& v = mc.values[static_cast<size_t>(i)];
    station(i) = v.station;
    error(i) = v.error;
    angle(i) = v.angle_deg;
    mean(i) = v.mean;
    std(i) = v.std;
    low(i) = v.low;
    high(i) = v.high;
    value(i) = v.linear_value;
    u(i) = v.linear_u;
    U(i) = v.linear_U;
    vm(i) = v.validated;
  }
  py::dict d;
  d["station"] = station;
  d["error"] = error;
  d["angle_deg"] = angle;
  d["mean"] = mean;
  d["std"] = std;
  d["low"] = low;
  d["high"] = high;
  d["linear_value"] = value;
  d["linear_u"] = u;
  d["linear_U"] = U;
  d["validated"] = validated;
  return d;
}

// pybind11's TypeError for arguments it cannot convert lists every overload over several lines
// and the repr of each argument given, at any length (a str of the caller's among them). Every
// function and method of the module raises it as one line instead: the signature, and the types
// given (never their values), cut at 1000 characters.
constexpr const char* kOneLineTypeErrors = R"py(
def _one_line_type_errors():
    import functools

    def shown(text, most):
        text = repr(str(text))[1:-1]
        return text if len(text) <= most else text[:most] + "... (cut)"

    def wrap(f):
        @functools.wraps(f)
        def call(*args, **kwargs):
            try:
                return f(*args, **kwargs)
            except TypeError as e:
                text = str(e)
                if "incompatible function arguments" not in text and \
                        "incompatible constructor arguments" not in text:
                    raise
                name = text.split("(", 1)[0]
                takes = " ".join(l.strip() for l in text.split("Invoked with")[0].splitlines()[1:]
                                 if l.strip())
                given = [type(a).__name__ for a in args] + \
                        ["%s=%s" % (k, type(v).__name__) for k, v in kwargs.items()]
                message = "%s(): incompatible arguments (given: %s); it takes %s" % (
                    shown(name, 100), shown(", ".join(given), 300), shown(takes, 500))
                raise TypeError(message) from None
        return call

    space = globals()
    for key, value in list(space.items()):
        if key.startswith("_"):
            continue
        if type(value).__name__ == "builtin_function_or_method":
            space[key] = wrap(value)
        elif isinstance(value, type) and value.__module__ == __name__:
            for attr, member in list(vars(value).items()):
                if attr.startswith("__") and attr not in ("__init__", "__getitem__"):
                    continue
                if isinstance(member, staticmethod):
                    setattr(value, attr, staticmethod(wrap(member.__func__)))
                elif type(member).__name__ == "instancemethod":
                    setattr(value, attr, wrap(member.__func__))

_one_line_type_errors()
del _one_line_type_errors
)py";

}  // namespace
}  // namespace dbbkit::python

PYBIND11_MODULE(dbbkit, m) {
  using namespace dbbkit;
  using namespace dbbkit::python;
  m.doc() =
      "dbbkit: the geometric errors of a rotary axis from double ball bar readings, their "
      "uncertainty, the "
      "design of the measurement and the closed loop on real data. Units: dx, dy, dz in um; ex, "
      "ey, ez in urad; "
      "angles in degrees; lengths in mm. Uncertainties are standard (k = 1) unless named U "
      "(expanded, k stated).";
  // Messages name the keyword arguments of this module, not the command line's options.
  set_option_style(OptionStyle::kPython);
  m.attr("__version__") = DBBKIT_VERSION;
  m.attr("ERROR_NAMES") = py::make_tuple("dx", "dy", "dz", "ex", "ey", "ez");
  m.attr("ERROR_UNITS") = py::make_tuple("um", "um", "um", "urad", "urad", "urad");

  static py::exception<InputError> input_error(m, "InputError", PyExc_ValueError);
  input_error.doc() =
      "Bad input: source (the file, or 'design', 'kit', 'measurements', 'truth', 'tolerances', "
      "'argument'), "
      "where (the line or key), detail (what is wrong).";
  py::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const InputError& e) {
      py::object instance = py::handle(input_error.ptr())(py::str(e.what()));
      instance.attr("source") = e.source();
      instance.attr("where") = e.where();
      instance.attr("detail") = e.detail();
      PyErr_SetObject(input_error.ptr(), instance.ptr());
    }
  });

  py::class_<PyDesign>(m, "Design",
                       "A measurement design (dbbkit.design/1), from a file path or a dict")
      .def(py::init([](py::handle source) { return make_design(source); }), py::arg("source"),
           "Design(path) reads a design file; Design(dict) takes the same keys. Raises InputError "
           "naming the key.")
      .def_property_readonly("source", [](const PyDesign& d) { return d.source; })
      .def_property_readonly("name", [](const PyDesign& d) { return d.value.name; })
      .def_property_readonly(
          "axis", [](const PyDesign& d) { return std::string(1, d.value.axis.letter()); },
          "The letter of the axis under test (A, B or C)")
      .def_property_readonly(
          "axis_frame",
          [](const PyDesign& d) { return to_python(io::axis_frame_to_json(d.value.axis)); },
          "The axis as a dict: letter, side, direction, reference, travel_deg, shorthand, "
          "ball_axes")
      .def_property_readonly("angles_deg",
                             [](const PyDesign& d) {
                               return Eigen::Map<const Eigen::VectorXd>(
                                   d.value.angles_deg.data(),
                                   static_cast<Eigen::Index>(d.value.angles_deg.size()));
                             })
      .def_property_readonly("installations",
                             [](const PyDesign& d) {
                               std::vector<std::string> ids;
                               for (const Installation& i : d.value.installations)
                                 ids.push_back(i.id);
                               return ids;
                             })
      .def(
          "to_dict", [](const PyDesign& d) { return to_python(io::design_to_json(d.value)); },
          "The design as the dict a design file holds")
      .def("__repr__", [](const PyDesign& d) {
        return "<dbbkit.Design '" + d.value.name + "' axis " + d.value.axis.label() + ", " +
               std::to_string(d.value.installations.size()) + " installations, " +
               std::to_string(d.value.angles_deg.size()) + " angles, " + d.value.errors.describe() +
               ">";
      });

  py::class_<PyKit>(m, "Kit", "A kit to search (dbbkit.kit/1), from a file path or a dict")
      .def(py::init([](py::handle source) { return make_kit(source); }), py::arg("source"))
      .def_property_readonly("source", [](const PyKit& k) { return k.source; })
      .def_property_readonly("name", [](const PyKit& k) { return k.value.name; })
      .def_property_readonly(
          "axis", [](const PyKit& k) { return std::string(1, k.value.axis.letter()); },
          "The letter of the axis under test (A, B or C)")
      .def_property_readonly(
          "axis_frame",
          [](const PyKit& k) { return to_python(io::axis_frame_to_json(k.value.axis)); },
          "The axis as a dict, as Design.axis_frame")
      .def("__repr__", [](const PyKit& k) {
        return "<dbbkit.Kit '" + k.value.name + "' axis " + k.value.axis.label() + ">";
      });

  py::class_<PyMeasurements>(m, "Measurements", "DBB readings checked against a design")
      .def(py::init([](py::handle path, const PyDesign& design) {
             const auto p = as_path(path);
             if (!p)
               throw InputError("argument", "path", "a measurement file path (str or os.PathLike)");
             return measurements_from_file(*p, design);
           }),
           py::arg("path"), py::arg("design"),
           "Measurements(path, design): a measurement CSV (formats.md)")
      .def_static(
          "from_csv",
          [](const std::string& text, const PyDesign& design, py::object source_obj) {
            const std::string source = text_of(source_obj, "argument", "source");
            PyMeasurements mm = measurements_of(design, source);
            mm.readings = io::parse_measurements(text, source);
            validate_readings(design.value, mm.readings, source);
            mm.from_text = true;
            return mm;
          },
          py::arg("text"), py::arg("design"), py::arg("source") = "csv", "The readings of CSV text")
      .def_static("from_arrays", &measurements_from_arrays, py::arg("design"),
                  py::arg("installation"), py::arg("angle_deg"), py::arg("reading_um"),
                  py::arg("time_s") = py::none(), py::arg("sweep") = py::none(),
                  py::arg("repeat") = py::none(),
                  "One reading per index: installation id, angle [deg], reading [um]; optional "
                  "time [s] (NaN: "
                  "not recorded), sweep ('cw', 'ccw' or None) and repeat")
      .def_static("from_trace", &measurements_from_trace, py::arg("design"), py::arg("traces"),
                  py::arg("dwell_s") = 2.0, py::arg("sweeps") = "ccw", py::arg("min_share") = 0.5,
                  py::arg("columns") = py::none(), py::arg("unit") = py::none(),
                  py::arg("sample_rate_hz") = py::none(),
                  py::arg("start_s") = std::map<std::string, double>{},
                  "`dbbkit readings`: traces (installation id -> a trace file or a (time_s, "
                  "reading_um) pair of arrays) to (Measurements, {'dwells': per id the dwells' "
                  "start_s, end_s, settled_start_s, settled_end_s, level_um, std_um, samples "
                  "arrays and noise_um, 'warnings': [...]}); start_s: {id: seconds}, each "
                  "trace's zero on the test's clock, for every trace or none")
      .def_property_readonly("source", [](const PyMeasurements& mm) { return mm.source; })
      .def("__len__", [](const PyMeasurements& mm) { return mm.readings.size(); })
      .def_property_readonly("installation",
                             [](const PyMeasurements& mm) {
                               std::vector<std::string> v;
                               for (const Reading& r : mm.readings) v.push_back(r.installation);
                               return v;
                             })
      .def_property_readonly("angle_deg",
                             [](const PyMeasurements& mm) {
                               Eigen::VectorXd v(static_cast<Eigen::Index>(mm.readings.size()));
                               for (size_t i = 0; i < mm.readings.size(); ++i)
                                 v(static_cast<Eigen::Index>(i)) = mm.readings[i].angle_deg;
                               return v;
                             })
      .def_property_readonly("reading_um",
                             [](const PyMeasurements& mm) {
                               Eigen::VectorXd v(static_cast<Eigen::Index>(mm.readings.size()));
                               for (size_t i = 0; i < mm.readings.size(); ++i)
                                 v(static_cast<Eigen::Index>(i)) = mm.readings[i].reading_um;
                               return v;
                             })
      .def_property_readonly("time_s",
                             [](const PyMeasurements& mm) {
                               Eigen::VectorXd v(static_cast<Eigen::Index>(mm.readings.size()));
                               for (size_t i = 0; i < mm.readings.size(); ++i) {
                                 v(static_cast<Eigen::Index>(i)) =
                                     mm.readings[i].time_s.value_or(kNaN);
                               }
                               return v;
                             })
      .def_property_readonly(
          "sweep",
          [](const PyMeasurements& mm) {
            py::list v;
            for (const Reading& r : mm.readings) {
              if (r.sweep)
                v.append(*r.sweep == Sweep::kCW ? "cw" : "ccw");
              else
                v.append(py::none());
            }
            return v;
          },
          "Per reading: 'ccw', 'cw', or None where not recorded")
      .def_property_readonly(
          "repeat",
          [](const PyMeasurements& mm) {
            py::list v;
            for (const Reading& r : mm.readings) {
              if (r.repeat)
                v.append(*r.repeat);
              else
                v.append(py::none());
            }
            return v;
          },
          "Per reading: its repeat number, or None where not recorded")
      .def_property_readonly(
          "std_um", [](const PyMeasurements& mm) { return optional_column(mm, &Reading::std_um); },
          "Per reading from a trace: the scatter of its samples [um] (NaN: not from a trace)")
      .def_property_readonly(
          "samples",
          [](const PyMeasurements& mm) { return optional_column(mm, &Reading::samples); },
          "Per reading from a trace: the number of samples averaged (NaN: not from a trace)")
      .def_property_readonly(
          "u_a_um", [](const PyMeasurements& mm) { return optional_column(mm, &Reading::u_a_um); },
          "Per reading from a trace: the Type A standard uncertainty of its mean from the "
          "dwell's 0.1 s batch means [um] (NaN: none)")
      .def_property_readonly(
          "u_a_dof",
          [](const PyMeasurements& mm) { return optional_column(mm, &Reading::u_a_dof); },
          "Per reading from a trace: the degrees of freedom of u_a_um (batches - 1; NaN: none)")
      .def(
          "to_csv",
          [](const PyMeasurements& mm) {
            std::ostringstream out;
            if (mm.design) {
              io::write_measurements_csv(out, mm.readings, *mm.design);
            } else {
              io::write_measurements_csv(out, mm.readings);
            }
            return out.str();
          },
          "The readings as a measurement CSV")
      .def("__repr__", [](const PyMeasurements& mm) {
        return "<dbbkit.Measurements " + std::to_string(mm.readings.size()) + " readings from " +
               mm.source + ">";
      });

  py::class_<PyMonteCarlo>(m, "MonteCarloResult",
                           "JCGM 101 propagation of distributions, per identified value")
      .def_property_readonly(
          "json", [](const PyMonteCarlo& r) { return to_python(io::monte_carlo_to_json(r.mc)); })
      .def_property_readonly("trials", [](const PyMonteCarlo& r) { return r.mc.trials; })
      .def_property_readonly("converged", [](const PyMonteCarlo& r) { return r.mc.converged; })
      .def_property_readonly("n_validated", [](const PyMonteCarlo& r) { return r.mc.n_validated; })
      .def_property_readonly(
          "arrays", [](const PyMonteCarlo& r) { return monte_carlo_arrays(r.mc); },
          "Per value: station, error (0..5), angle_deg, mean, std, low, high (the "
          "probabilistically "
          "symmetric interval), linear_value, linear_u, linear_U, validated")
      .def("summary", [](const PyMonteCarlo& r) { return io::monte_carlo_summary(r.mc); });

  py::class_<PyEvaluateResult>(m, "EvaluateResult",
                               "What a design can identify, and how well, before measuring")
      .def_property_readonly(
          "json", [](const PyEvaluateResult& r) { return to_python(r.json); },
          "The dict `dbbkit evaluate --out` writes")
      .def_property_readonly("angles_deg",
                             [](const PyEvaluateResult& r) { return angles_array(r.ev.errors); })
      .def_property_readonly(
          "std", [](const PyEvaluateResult& r) { return errors_array(r.ev.errors, false); },
          "(stations, 6): the reading-noise standard uncertainty (k = 1) of dx..ez [um, urad]; "
          "NaN where not determined")
      .def_property_readonly(
          "std_total",
          [](const PyEvaluateResult& r) -> py::object {
            if (!r.ev.setup_included) return py::none();
            return py::cast(errors_array(r.ev.total_errors, false));
          },
          "(stations, 6): noise and declared set-up tolerances; None when none are declared")
      .def_property_readonly("worst_std_um",
                             [](const PyEvaluateResult& r) -> py::object {
                               return r.json.contains("worst_std_um")
                                          ? to_python(r.json.at("worst_std_um"))
                                          : py::none();
                             })
      .def_property_readonly("singular_values",
                             [](const PyEvaluateResult& r) { return r.ev.prior.singular_values; })
      .def_property_readonly("rank", [](const PyEvaluateResult& r) { return r.ev.prior.rank; })
      .def_property_readonly(
          "warnings", [](const PyEvaluateResult& r) { return warnings_list(r.ev.warnings); },
          "What makes the stated uncertainties unreliable: a list of {'kind', 'text'}")
      .def_property_readonly("n_unknowns",
                             [](const PyEvaluateResult& r) { return r.ev.prior.n_unknowns; })
      .def_property_readonly("monte_carlo",
                             [](const PyEvaluateResult& r) -> py::object {
                               return r.mc ? py::cast(PyMonteCarlo{*r.mc}) : py::none();
                             })
      .def("summary",
           [](const PyEvaluateResult& r) { return io::evaluate_summary(r.design->value, r.ev); })
      .def("report", &PyEvaluateResult::report, py::arg("format") = "html")
      .def("_repr_html_", [](const PyEvaluateResult& r) { return iframe(r.report("html")); });

  py::class_<PyIdentifyResult>(m, "IdentifyResult",
                               "The identified errors with their uncertainty budget")
      .def_property_readonly(
          "json", [](const PyIdentifyResult& r) { return to_python(r.json); },
          "The dict `dbbkit identify --out` writes")
      .def_property_readonly(
          "iso230", [](const PyIdentifyResult& r) { return PyIso230{r.result().iso}; },
          "The ISO 230 quantities (Iso230): location errors, constant parts, component error "
          "motions, typed")
      .def_property_readonly(
          "angles_deg", [](const PyIdentifyResult& r) { return angles_array(r.result().errors); })
      .def_property_readonly(
          "values", [](const PyIdentifyResult& r) { return errors_array(r.result().errors, true); },
          "(stations, 6): dx, dy, dz [um], ex, ey, ez [urad]; NaN where not determined")
      .def_property_readonly(
          "std", [](const PyIdentifyResult& r) { return errors_array(r.result().errors, false); },
          "(stations, 6): combined standard uncertainty u_c (k = 1) of the budget")
      .def_property_readonly(
          "U", [](const PyIdentifyResult& r) { return r.budget_array(true); },
          "(stations, 6): expanded uncertainty k u_c at the coverage probability")
      .def_property_readonly(
          "k", [](const PyIdentifyResult& r) { return r.budget_array(false); },
          "(stations, 6): the coverage factor of each value (Student t at nu_eff)")
      .def_property_readonly(
          "coverage_probability",
          [](const PyIdentifyResult& r) { return r.result().budget.coverage_probability; })
      .def_property_readonly(
          "determined",
          [](const PyIdentifyResult& r) { return determined_array(r.result().errors); })
      .def("covariance", &PyIdentifyResult::covariance,
           "(6 x stations, 6 x stations): the joint covariance of the values (row 6 s + k: error k "
           "at "
           "station s), with "
           "every component of u_c and their correlations; its diagonal is std**2; NaN where not "
           "determined")
      .def_property_readonly(
          "residuals_um", [](const PyIdentifyResult& r) { return r.result().estimate.residual_um; },
          "Reading minus the model's reading [um], in the order of the measurements")
      .def_property_readonly(
          "singular_values",
          [](const PyIdentifyResult& r) { return r.result().estimate.singular_values; },
          "Of the column-equilibrated whitened Jacobian, descending")
      .def_property_readonly("rank",
                             [](const PyIdentifyResult& r) { return r.result().estimate.rank; })
      .def_property_readonly(
          "n_unknowns", [](const PyIdentifyResult& r) { return r.result().estimate.n_unknowns; })
      .def_property_readonly(
          "n_readings", [](const PyIdentifyResult& r) { return r.result().estimate.n_readings; })
      .def_property_readonly(
          "warnings", [](const PyIdentifyResult& r) { return warnings_list(r.result().warnings); },
          "What makes the stated uncertainties unreliable here: a list of {'kind', 'text'}, "
          "empty when nothing does")
      .def_property_readonly("chi2",
                             [](const PyIdentifyResult& r) { return r.result().estimate.chi2; })
      .def_property_readonly("dof",
                             [](const PyIdentifyResult& r) { return r.result().estimate.dof; })
      .def_property_readonly("p_value",
                             [](const PyIdentifyResult& r) { return r.result().estimate.p_value; })
      .def_property_readonly(
          "budget", [](const PyIdentifyResult& r) { return to_python(r.json.at("budget")); },
          "The JCGM 100 budget of every value (components, u_c, nu_eff, k, U)")
      .def_property_readonly("monte_carlo",
                             [](const PyIdentifyResult& r) -> py::object {
                               return r.mc ? py::cast(PyMonteCarlo{*r.mc}) : py::none();
                             })
      .def_property_readonly(
          "conforms",
          [](const PyIdentifyResult& r) -> py::object {
            if (!r.conformance) return py::none();
            return py::bool_(!r.conformance->any_nonconforming());
          },
          "With tolerances: False when a quantity does not conform (ISO 14253-1), else True; "
          "None without tolerances")
      .def(
          "summary",
          [](const PyIdentifyResult& r) {
            std::string s = io::identify_summary(r.design->value, r.result());
            if (r.mc) s += io::monte_carlo_summary(*r.mc);
            if (r.conformance) s += io::conformance_text(*r.conformance);
            return s;
          },
          "The tables `dbbkit identify` prints")
      .def("report", &PyIdentifyResult::report, py::arg("format") = "html")
      .def("_repr_html_", [](const PyIdentifyResult& r) { return iframe(r.report("html")); });

  py::class_<PyDiagnoseResult>(m, "DiagnoseResult",
                               "What the model does not explain, the effects added, before/after")
      .def_property_readonly(
          "json", [](const PyDiagnoseResult& r) { return to_python(r.json); },
          "The dict `dbbkit diagnose --out` writes")
      .def_property_readonly(
          "warnings", [](const PyDiagnoseResult& r) { return warnings_list(r.result.warnings); },
          "What makes the corrected errors' uncertainties unreliable: a list of {'kind', 'text'}")
      .def_property_readonly(
          "iso230", [](const PyDiagnoseResult& r) { return PyIso230{r.result.iso_after}; },
          "The corrected errors' ISO 230 quantities (Iso230), the attributions' share in their "
          "std")
      .def(
          "covariance_after", &PyDiagnoseResult::covariance_after,
          "(6 x stations, 6 x stations): the final model's covariance of the errors after (row 6 s "
          "+ k: error k at station s); NaN where not determined. The attributions' share is in "
          "std_after only: where there is one, std_after**2 exceeds this diagonal by it")
      .def_property_readonly(
          "brief", [](const PyDiagnoseResult& r) { return to_python(r.json["summary"]); },
          "The answer in at most six sentences (what was found, how sure, what it changes, what "
          "to do next): a list of {'topic', 'text'}, the JSON's 'summary'")
      .def_property_readonly(
          "angles_deg",
          [](const PyDiagnoseResult& r) { return angles_array(r.result.errors_before); })
      .def_property_readonly(
          "values_before",
          [](const PyDiagnoseResult& r) { return errors_array(r.result.errors_before, true); })
      .def_property_readonly(
          "std_before",
          [](const PyDiagnoseResult& r) { return errors_array(r.result.errors_before, false); })
      .def_property_readonly(
          "values_after",
          [](const PyDiagnoseResult& r) { return errors_array(r.result.errors_after, true); })
      .def_property_readonly(
          "std_after",
          [](const PyDiagnoseResult& r) { return errors_array(r.result.errors_after, false); })
      .def_property_readonly("residuals_before_um",
                             [](const PyDiagnoseResult& r) { return r.result.before.residual_um; })
      .def_property_readonly("residuals_after_um",
                             [](const PyDiagnoseResult& r) { return r.result.after.residual_um; })
      .def_property_readonly("rms_before_um",
                             [](const PyDiagnoseResult& r) { return r.result.before.rms_um; })
      .def_property_readonly("rms_after_um",
                             [](const PyDiagnoseResult& r) { return r.result.after.rms_um; })
      .def_property_readonly(
          "added", [](const PyDiagnoseResult& r) { return to_python(r.json.at("added_effects")); },
          "The effects added, with values and evidence (as in the JSON)")
      .def_property_readonly("verdict",
                             [](const PyDiagnoseResult& r) {
                               return io::diagnose_verdict(r.design->value, r.data->readings,
                                                           r.result);
                             })
      .def_property_readonly(
          "conforms",
          [](const PyDiagnoseResult& r) -> py::object {
            if (!r.conformance) return py::none();
            return py::bool_(!r.conformance->any_nonconforming());
          },
          "With tolerances: False when a corrected quantity does not conform (ISO 14253-1), else "
          "True; None without tolerances")
      .def(
          "summary",
          [](const PyDiagnoseResult& r) {
            std::string s = io::diagnose_summary(r.design->value, r.data->readings, r.result);
            if (r.conformance) s += io::conformance_text(*r.conformance);
            return s;
          },
          "The tables `dbbkit diagnose` prints")
      .def("report", &PyDiagnoseResult::report, py::arg("format") = "html")
      .def("_repr_html_", [](const PyDiagnoseResult& r) { return iframe(r.report("html")); });

  py::class_<PyOptimizeResult>(m, "OptimizeResult",
                               "The search of a kit: the best design, every choice, the front")
      .def_property_readonly(
          "json", [](const PyOptimizeResult& r) { return to_python(r.json); },
          "The dict `dbbkit optimize --result` writes")
      .def_property_readonly(
          "design",
          [](const PyOptimizeResult& r) -> py::object {
            if (!r.result.best) return py::none();
            return py::cast(PyDesign{io::optimized_design(r.kit->value, r.result, r.kit->source),
                                     "optimized design", false});
          },
          "The best design (what `dbbkit optimize --out` writes); None when no choice is feasible")
      .def_property_readonly("seconds", [](const PyOptimizeResult& r) { return r.seconds; })
      .def(
          "summary",
          [](const PyOptimizeResult& r, bool pareto) {
            return io::optimize_summary(r.kit->value, r.result, r.kit->source, r.seconds,
                                        r.reference, pareto);
          },
          py::arg("pareto") = false)
      .def("report", &PyOptimizeResult::report, py::arg("format") = "html")
      .def("_repr_html_", [](const PyOptimizeResult& r) { return iframe(r.report("html")); });

  // A result for compare and compensation: a path, an IdentifyResult or DiagnoseResult, or the
  // dict their json gives.
  // A str that begins with '{' is a result's JSON text, not a file's name.
  auto json_text = [](py::handle h) -> std::optional<std::string> {
    if (!py::isinstance<py::str>(h)) return std::nullopt;
    std::string text = h.cast<std::string>();
    const std::size_t first = text.find_first_not_of(" \t\r\n");
    if (first == std::string::npos || text[first] != '{') return std::nullopt;
    return text;
  };
  // The SHA-256 of a result given as a file or as its JSON text (empty for an object or a dict:
  // no bytes were read).
  auto result_sha = [json_text](py::handle h) -> std::string {
    if (const auto text = json_text(h)) return io::sha256_hex(*text);
    if (const auto path = as_path(h)) return io::sha256_file(*path);
    return "";
  };
  auto result_of = [json_text](py::handle h, const char* name) {
    if (const auto text = json_text(h)) return io::result_from_text(*text, name);
    if (const auto path = as_path(h)) return io::read_result_file(*path);
    nlohmann::json j;
    if (py::isinstance<PyIdentifyResult>(h)) {
      j = h.cast<const PyIdentifyResult&>().json;
    } else if (py::isinstance<PyDiagnoseResult>(h)) {
      j = h.cast<const PyDiagnoseResult&>().json;
    } else {
      j = from_python(h, name, "");
    }
    return io::result_from_text(io::dump_json(j), name);
  };
  m.def(
      "compare",
      [result_of](py::handle a, py::handle b, double level) {
        check_finite_in("level", level, limits::kMinCompareLevel, limits::kMaxCompareLevel);
        return to_python(io::comparison_to_json(
            io::compare_results(result_of(a, "a"), result_of(b, "b"), level)));
      },
      py::arg("a"), py::arg("b"), py::arg("level") = 0.05,
      "`dbbkit compare`: the change B - A of every location error, constant part and error motion "
      "value of two results of one axis (paths, results or their json), its uncertainty and "
      "whether it is significant at the family-wise level; the dict `compare --out` writes");
  m.def(
      "chain",
      [result_of, json_text](py::handle machine, const std::vector<py::handle>& results,
                             double coverage) {
        check_finite_in("coverage", coverage, limits::kMinCoverage, limits::kMaxCoverage);
        const auto path = as_path(machine);
        const Machine mm =
            path ? io::read_machine_file(*path)
                 : io::machine_from_json(from_python(machine, "machine", ""), "machine");
        std::vector<ChainInput> in;
        for (std::size_t i = 0; i < results.size(); ++i) {
          const std::string name = "results[" + std::to_string(i) + "]";
          in.push_back(io::chain_input(mm, result_of(results[i], name.c_str())));
          if (json_text(results[i])) continue;  // from no file
          if (const auto p = as_path(results[i])) in.back().sha256 = io::sha256_file(*p);
        }
        return to_python(io::chain_to_json(chain_machine(mm, in, coverage), mm,
                                           path ? *path : std::string("machine"),
                                           path ? io::sha256_file(*path) : std::string()));
      },
      py::arg("machine"), py::arg("results"), py::arg("coverage") = 0.95,
      "`dbbkit chain`: the results of a machine's axes (paths, results or their json) combined "
      "on the controller's reference: each axis' location errors in its carrier's body and the "
      "distance and squareness between their lines, with U; the dict `chain --out` writes");
  m.def(
      "predict",
      [result_of, result_sha, json_text](
          py::handle result, py::handle at, double coverage, bool location_only,
          std::optional<std::vector<double>> radii_mm,
          std::optional<std::vector<double>> heights_mm, py::handle around,
          std::optional<std::vector<double>> angles_deg, const std::optional<PyDesign>& design) {
        check_finite_in("coverage", coverage, limits::kMinCoverage, limits::kMaxCoverage);
        if (design) {  // a test's readings before it is run, as predict --design
          if (!at.is_none() || radii_mm)
            throw InputError("design", "",
                             "give the poses (at), a map (radii_mm) or a test "
                             "(design), one of them");
          io::TestPrediction t = io::predict_test(result_of(result, "result"), design->value,
                                                  design->source, coverage, location_only);
          t.result_sha256 = result_sha(result);
          return to_python(io::test_prediction_to_json(t));
        }
        // A machine result (a path or its JSON text): its chain at poses, as predict --result
        // M.json.
        std::optional<std::string> text = json_text(result);
        if (!text)
          if (const auto path = as_path(result)) {
            const std::string read = io::read_json_file(*path);
            if (io::is_chain_text(read)) text = read;
          }
        if (text && io::is_chain_text(*text)) {
          if (at.is_none() || radii_mm || design || location_only)
            throw InputError("at", "",
                             "a machine result is predicted at poses (at: a CSV's path or rows "
                             "[one angle per axis, x_mm, y_mm, z_mm; a table and a head: and "
                             "tool_x_mm, tool_y_mm, tool_z_mm]) alone");
          const std::string source =
              as_path(result) && !json_text(result) ? *as_path(result) : std::string("result");
          const io::ChainFile f = io::chain_from_text(*text, source);
          const ChainErrors chain = io::chain_errors_of(f);
          std::vector<ChainPose> poses;
          std::string poses_source = "at";
          if (const auto path = as_path(at)) {
            poses = io::parse_chain_poses(io::read_text_file(*path), *path, chain);
            poses_source = *path;
          } else {
            const std::vector<std::string> columns = io::chain_pose_columns(chain);
            const std::vector<std::vector<double>> rows = number_rows(at, "at", columns);
            for (std::size_t i = 0; i < rows.size(); ++i)
              poses.push_back(io::chain_pose_of(
                  chain, columns, [&](std::size_t k) { return rows[i][k]; }, "at",
                  "at[" + std::to_string(i) + "]"));
          }
          io::ChainPredictResult p = io::predict_chain(f, chain, poses, coverage);
          p.poses_source = poses_source;
          p.result_sha256 = io::sha256_hex(*text);
          return to_python(io::chain_prediction_to_json(p));
        }
        const std::optional<io::GridRequest> request =
            grid_request(radii_mm, heights_mm, around, angles_deg);
        if (at.is_none() && !radii_mm)
          throw InputError("at", "", "give the poses (at), a map (radii_mm) or a test (design)");
        if (!at.is_none() && radii_mm)
          throw InputError("at", "", "give the poses (at) or a map (radii_mm), not both");
        const io::ResultFile r = result_of(result, "result");
        std::vector<Pose> poses;
        std::optional<EnvelopeGrid> grid;
        std::string source = "at";
        if (radii_mm) {
          // A map, as predict --grid-radius-mm makes it.
          grid = io::grid_of(r, *request, kGridKeys);
          poses = envelope_poses(r.axis, *grid);
          source = "grid";
        } else if (const auto path = as_path(at)) {
          poses = io::read_poses_file(*path, r.axis);
          source = *path;
        } else {
          const std::vector<std::vector<double>> rows =
              number_rows(at, "at", {"angle_deg", "x_mm", "y_mm", "z_mm"});
          for (std::size_t i = 0; i < rows.size(); ++i) {
            const std::string where = "at[" + std::to_string(i) + "]";
            Pose p;
            p.angle_deg = rows[i][0];
            p.point_mm = Eigen::Vector3d(rows[i][1], rows[i][2], rows[i][3]);
            io::check_pose(p, r.axis, "at", where + ".");
            poses.push_back(p);
          }
        }
        io::PredictResult p = io::predict(r, poses, coverage, location_only);
        p.poses_source = source;
        p.grid = grid;
        p.result_sha256 = result_sha(result);
        return to_python(io::prediction_to_json(p));
      },
      py::arg("result"), py::arg("at") = py::none(), py::arg("coverage") = 0.95,
      py::arg("location_only") = false, py::arg("radii_mm") = py::none(),
      py::arg("heights_mm") = py::none(), py::arg("around") = py::none(),
      py::arg("angles_deg") = py::none(), py::arg("design") = py::none(),
      "`dbbkit predict`: the error of points of the turning body at commanded angles (`at`: a "
      "poses CSV's path, or rows [angle_deg, x_mm, y_mm, z_mm]; or a map: `radii_mm` from the "
      "axis line, `heights_mm` along it (default [0]), `around` points a circle (default 8), "
      "`angles_deg` "
      "(default the result's), as predict --grid-*) from a result (path, result or its json), "
      "with its uncertainty and what entering the location errors leaves; or, with `design` (a "
      "test of the same axis), each of its readings before it is run, with U, as predict "
      "--design; from a machine result (dbbkit chain --out, a path or its JSON text), `at` "
      "rows [one angle per axis in the result's axes order, x_mm, y_mm, z_mm] (a table and a "
      "head: and tool_x_mm, tool_y_mm, tool_z_mm) or a CSV with those columns; the dict "
      "`predict --out` writes");
  m.def(
      "verify",
      [result_of, result_sha](py::handle result, const PyDesign& design, const PyMeasurements& data,
                              double coverage, bool location_only) {
        check_finite_in("coverage", coverage, limits::kMinCoverage, limits::kMaxCoverage);
        const io::ResultFile r = result_of(result, "result");
        io::check_test_axis(r, design.value, design.source);
        validate_against(design, data);
        io::VerifyReport v = io::verify(r, design.value, data.readings, design.source, data.source,
                                        coverage, location_only);
        v.result_sha256 = result_sha(result);
        return to_python(io::verification_to_json(v));
      },
      py::arg("result"), py::arg("design"), py::arg("data"), py::arg("coverage") = 0.95,
      py::arg("location_only") = false,
      "`dbbkit verify`: a held-out check: the readings of another test of the same axis "
      "(design and data, as identify takes them) predicted from a result (path, result or its "
      "json) and compared with what was read; the dict `verify --out` writes ('pass': whether "
      "the result explains the test)");
  m.def(
      "compensation",
      [result_of](py::handle result, const std::string& format, const std::string& kins,
                  const std::map<std::string, double>& current, double k, int record,
                  std::optional<std::vector<double>> radii_mm,
                  std::optional<std::vector<double>> heights_mm, py::handle around,
                  std::optional<std::vector<double>> angles_deg,
                  std::optional<std::vector<double>> tool_reference_mm) {
        const std::optional<io::GridRequest> request =
            grid_request(radii_mm, heights_mm, around, angles_deg);
        check_finite_in("k", k, limits::kMinCoverageFactor, limits::kMaxCoverageFactor);
        if (record != 0)
          check_integer_in("record", record, limits::kMinSwivelRecord, limits::kMaxSwivelRecord);
        const io::CompensationFormat f = io::compensation_format(format, "argument");
        io::CompensationOptions o;
        o.k = k;
        o.linuxcnc_kins = kins;
        o.record = record;
        if (tool_reference_mm) {
          if (tool_reference_mm->size() != 3)
            throw InputError("tool_reference_mm", "", "expected the point [x, y, z] in mm");
          for (const double x : *tool_reference_mm)
            check_finite_in("tool_reference_mm", x, -io::kMaxCompensation_mm,
                            io::kMaxCompensation_mm);
          o.tool_reference_mm = Eigen::Vector3d((*tool_reference_mm)[0], (*tool_reference_mm)[1],
                                                (*tool_reference_mm)[2]);
        }
        for (const auto& [pin, v] : current) {
          check_finite_in("current", v, -io::kMaxCompensation_mm, io::kMaxCompensation_mm);
          o.current_mm[pin] = v;
        }
        io::check_compensation_options(f, o);  // before the result is read
        // A machine result (chain): a path to one, or the dict chain gives.
        if (const auto path = as_path(result)) {
          const std::string text = io::read_json_file(*path);
          if (io::is_chain_text(text)) {
            if (request) throw InputError("radii_mm", "", kMachineEnvelope);
            return io::machine_compensation_text(io::chain_from_text(text, *path), f, o);
          }
        } else if (py::isinstance<py::dict>(result)) {
          const nlohmann::json j = from_python(result, "result", "");
          if (j.is_object() && j.contains("format") && j["format"] == io::kChainFormat) {
            if (request) throw InputError("radii_mm", "", kMachineEnvelope);
            return io::machine_compensation_text(io::chain_from_text(io::dump_json(j), "result"), f,
                                                 o);
          }
        }
        const io::ResultFile r = result_of(result, "result");
        if (request) o.envelope = io::grid_of(r, *request, kGridKeys);
        return io::compensation_text(r, f, o);
      },
      py::arg("result"), py::arg("format"), py::arg("kins") = "",
      py::arg("current") = std::map<std::string, double>{}, py::arg("k") = 2.0,
      py::arg("record") = 0, py::arg("radii_mm") = py::none(), py::arg("heights_mm") = py::none(),
      py::arg("around") = py::none(), py::arg("angles_deg") = py::none(),
      py::arg("tool_reference_mm") = py::none(),
      "`dbbkit compensation`: the location errors of a result, or a machine result's corrected "
      "kinematics (chain), for a controller (format isg, linuxcnc, siemens: record, and on a "
      "machine with a head axis tool_reference_mm [x, y, z], as --tool-reference-mm; or table), "
      "as the text the command writes; radii_mm, heights_mm, around, angles_deg: the envelope "
      "the decision to enter rests on, as --grid-*");

  constexpr std::uint64_t kSeed = 1;
  m.def("evaluate", &run_evaluate, py::arg("design"), py::arg("reference_length_mm") = py::none(),
        py::arg("monte_carlo") = false, py::arg("coverage") = 0.95, py::arg("mc_seed") = kSeed,
        py::arg("mc_threads") = 1, py::arg("mc_max_trials") = 2000000L,
        py::arg("mc_batch") = 10000L, py::arg("mc_digits") = 2,
        "`dbbkit evaluate`: the a-priori uncertainty of a design (no readings)");
  m.def("identify", &run_identify, py::arg("design"), py::arg("measurements"),
        py::arg("type_a") = false, py::arg("coverage") = 0.95, py::arg("tolerances") = py::none(),
        py::arg("monte_carlo") = false, py::arg("mc_seed") = kSeed, py::arg("mc_threads") = 1,
        py::arg("mc_max_trials") = 2000000L, py::arg("mc_batch") = 10000L, py::arg("mc_digits") = 2,
        py::arg("effects") = py::none(), py::arg("type_a_readings") = false,
        "`dbbkit identify`: the six errors from the readings, their budget (JCGM 100), ISO 230-7 "
        "terms, with tolerances (a path or dict, dbbkit.tolerances/1) the conformance "
        "decisions, and with effects (labels as diagnose names them, a list or a comma-separated "
        "string) those effects fitted with the errors; type_a_readings: each reading's own Type "
        "A (u_a_um, u_a_dof from dbbkit readings) beside the declared instrument");
  m.def("diagnose", &run_diagnose, py::arg("design"), py::arg("measurements"),
        py::arg("level") = 0.01, py::arg("max_effects") = 12, py::arg("exclude_gross") = false,
        py::arg("tolerances") = py::none(),
        "`dbbkit diagnose`: the closed loop, before and after (exclude_gross: refit without the "
        "gross readings found, and say so; tolerances, a path or dict, dbbkit.tolerances/1: the "
        "conformance of the corrected errors)");
  m.def("optimize", &run_optimize, py::arg("kit"), py::arg("criterion") = py::none(),
        py::arg("threads") = 0, py::arg("require_setup_detection") = false,
        py::arg("reference") = py::none(),
        "`dbbkit optimize`: the design of the kit with the smallest worst-case uncertainty "
        "(criterion: worst, "
        "worst_total, D, A, E, condition); the result does not depend on threads");
  py::class_<IsoQuantity>(m, "IsoQuantity", "An ISO 230 quantity: name, unit, value and std")
      .def_readonly("name", &IsoQuantity::name)
      .def_readonly("unit", &IsoQuantity::unit)
      .def_property_readonly("determined", [](const IsoQuantity& q) { return q.value.determined; })
      .def_property_readonly(
          "value", [](const IsoQuantity& q) { return optional_float(q.value, false); },
          "None when not determined")
      .def_property_readonly(
          "std", [](const IsoQuantity& q) { return optional_float(q.value, true); },
          "Standard uncertainty (k = 1); None when not determined")
      .def("__repr__", [](const IsoQuantity& q) {
        return "<dbbkit.IsoQuantity " + q.name + " = " +
               (q.value.determined ? io::fmt_num(q.value.value, 6) + " +- " +
                                         io::fmt_num(q.value.std, 3) + " " + q.unit
                                   : std::string("not determined")) +
               ">";
      });
  py::class_<PyIso230>(m, "Iso230",
                       "The ISO 230 quantities of a result (the JSON's 'iso230', typed): "
                       "location errors, constant parts, component error motions")
      .def_property_readonly(
          "location", [](const PyIso230& r) { return r.iso.location; },
          "The five location errors (e.g. X0C, Y0C, A0C, B0C, C0C) as IsoQuantity")
      .def_property_readonly(
          "constants", [](const PyIso230& r) { return r.iso.constants; },
          "The constant parts (where the readings' zero was taken; not location errors)")
      .def(
          "__getitem__",
          [](const PyIso230& r, const std::string& name) {
            for (const IsoQuantity& q : r.iso.location)
              if (q.name == name) return q;
            for (const IsoQuantity& q : r.iso.constants)
              if (q.name == name) return q;
            throw py::key_error(name);
          },
          "A location error or constant part by its name, e.g. iso['X0C']")
      .def_property_readonly("component_names",
                             [](const PyIso230& r) {
                               return std::vector<std::string>(r.iso.component_names.begin(),
                                                               r.iso.component_names.end());
                             })
      .def_property_readonly(
          "component_angles_deg",
          [](const PyIso230& r) {
            Eigen::VectorXd v(static_cast<Eigen::Index>(r.iso.components.size()));
            for (std::size_t i = 0; i < r.iso.components.size(); ++i)
              v(static_cast<Eigen::Index>(i)) = r.iso.components[i].angle_deg;
            return v;
          })
      .def_property_readonly(
          "components", [](const PyIso230& r) { return iso_components(r.iso, false); },
          "(angles, 6): the component error motions in component_names' order [um, urad]; NaN "
          "where not determined")
      .def_property_readonly(
          "components_std", [](const PyIso230& r) { return iso_components(r.iso, true); },
          "(angles, 6): their standard uncertainties (k = 1)")
      .def_property_readonly(
          "motion_values",
          [](const PyIso230& r) {
            py::list out;
            for (const IsoMotionValue& v : r.iso.motion_values.values) {
              py::dict d;
              d["name"] = v.name;
              d["component"] = v.component;
              d["unit"] = v.unit;
              d["computed"] = v.computed;
              d["value"] = v.computed ? py::object(py::float_(v.value)) : py::none();
              d["U"] = v.computed ? py::object(py::float_(v.U)) : py::none();
              d["low"] = v.computed ? py::object(py::float_(v.low)) : py::none();
              d["high"] = v.computed ? py::object(py::float_(v.high)) : py::none();
              out.append(d);
            }
            return out;
          },
          "The error motion values (ranges) with their interval: a list of dicts");
  py::class_<PySetupSheet>(m, "SetupSheet",
                           "The design as a person sets it up (`dbbkit setup-sheet`): the order, "
                           "each installation's hardware and moves, a drawing of each")
      .def(
          "summary", [](const PySetupSheet& r) { return io::setup_sheet_summary(r.sheet); },
          "The lines `dbbkit setup-sheet` prints")
      .def("report", &PySetupSheet::report, py::arg("format") = "html",
           "The sheet as `--report` (html) or `--summary` (markdown) writes it")
      .def_property_readonly(
          "fits_kit", [](const PySetupSheet& r) { return r.sheet.fits_kit(); },
          "Every installation stays in the kit's travel and clears its workspace (True without "
          "a kit)")
      .def_property_readonly(
          "order",
          [](const PySetupSheet& r) {
            std::vector<std::string> ids;
            for (const SetupStep& st : r.sheet.order.steps)
              ids.push_back(r.sheet.design.installations[st.installation].id);
            return ids;
          },
          "The installations in the order to set them up")
      .def("_repr_html_", [](const PySetupSheet& r) { return iframe(r.report("html")); });
  m.def("program", &run_program, py::arg("design"), py::arg("dialect"), py::arg("kit") = py::none(),
        py::arg("program_number") = py::none(), py::arg("sweeps") = "ccw", py::arg("dwell_s") = 2.0,
        py::arg("feed_mm_min") = 500.0, py::arg("path_tolerance_mm") = 0.05,
        py::arg("tool") = kDefaultBallbarTool, py::arg("clearance_z_mm") = py::none(),
        py::arg("clearance_margin_mm") = 50.0, py::arg("air_run") = false,
        py::arg("orient_code") = "M19", py::arg("tcpm") = py::none(),
        "`dbbkit program`: the part program of the measurement (dialect iso, heidenhain or "
        "sinumerik) as a str; with a kit, refused (InputError) when the design leaves its travel "
        "or clashes with its workspace; tcpm 'on' or 'off' (required when the design names its "
        "machine)");
  m.def("setup_sheet", &run_setup_sheet, py::arg("design"), py::arg("kit") = py::none(),
        py::arg("resolution_mm") = py::none(), py::arg("sweeps") = "ccw", py::arg("dwell_s") = 2.0,
        py::arg("feed_mm_min") = 500.0, py::arg("path_tolerance_mm") = 0.05,
        py::arg("tool") = kDefaultBallbarTool, py::arg("clearance_z_mm") = py::none(),
        py::arg("clearance_margin_mm") = 50.0, py::arg("air_run") = false,
        py::arg("orient_code") = "M19", py::arg("tcpm") = py::none(),
        "`dbbkit setup-sheet`: the set-up sheet of a design (with a kit: its times, resolution, "
        "travel and workspace checked)");
  m.def("simulate", &run_simulate, py::arg("design"), py::arg("truth"),
        py::arg("seed") = py::none(),
        "`dbbkit simulate`: synthetic readings from a truth (a path or dict, dbbkit.truth/1)");
  py::exec(kOneLineTypeErrors, m.attr("__dict__"));
}
