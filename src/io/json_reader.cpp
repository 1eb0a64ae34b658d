#include "dbbkit/io/json_reader.hpp"

#include <algorithm>
#include <array>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>
#include <vector>

#include "dbbkit/error.hpp"
#include "dbbkit/limits.hpp"
#include "dbbkit/user_text.hpp"
#include "object_reader.hpp"

namespace dbbkit::io {

using nlohmann::json;

std::string read_text_file(const std::string& path) {
  return read_text_file(path, limits::kMaxInputBytes);
}

std::string read_json_file(const std::string& path) {
  // One byte more than a JSON input may hold: parse_json names what is too long.
  return read_text_file(path, limits::kMaxJsonBytes + 1);
}

std::string read_text_file(const std::string& path, std::size_t max_bytes) {
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec))
    throw InputError(path, "", "is a directory, not a file");
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path, "", "cannot open the file for reading");
  // Read in pieces and stop at the limit: a FIFO or a device such as /dev/zero never ends.
  std::string text;
  std::array<char, 1 << 16> buf;
  while (in) {
    in.read(buf.data(), static_cast<std::streamsize>(buf.size()));
    text.append(buf.data(), static_cast<size_t>(in.gcount()));
    if (text.size() > max_bytes) {
      if (max_bytes < limits::kMaxInputBytes) break;  // the reader of the format says more
      throw InputError(
          path, "",
          "longer than " + std::to_string(limits::kMaxInputBytes >> 20) +
              " MiB, the most dbbkit reads from one input (docs/formats.md, \"Limits\")");
    }
  }
  if (in.bad()) throw InputError(path, "", "error while reading the file");
  return text;
}

bool parse_decimal(const std::string& text, double& out) {
  size_t i = 0;
  const size_t n = text.size();
  auto digits = [&]() {
    const size_t start = i;
    while (i < n && text[i] >= '0' && text[i] <= '9') ++i;
    return i - start;
  };
  if (i < n && (text[i] == '+' || text[i] == '-')) ++i;
  size_t mantissa = digits();
  if (i < n && text[i] == '.') {
    ++i;
    mantissa += digits();
  }
  if (mantissa == 0) return false;
  if (i < n && (text[i] == 'e' || text[i] == 'E')) {
    ++i;
    if (i < n && (text[i] == '+' || text[i] == '-')) ++i;
    if (digits() == 0) return false;
  }
  if (i != n) return false;
  errno = 0;
  const double x = std::strtod(text.c_str(), nullptr);
  if (errno == ERANGE || !std::isfinite(x)) return false;
  out = x;
  return true;
}

bool underflows(const std::string& text) {
  // A number whose digits are not all zero and that strtod takes to 0 or below DBL_MIN.
  if (text.find_first_of("123456789") == std::string::npos) return false;
  const size_t e = text.find_first_of("eE");
  if (text.find_first_of("123456789") > (e == std::string::npos ? text.size() : e)) return false;
  errno = 0;
  const double x = std::strtod(text.c_str(), nullptr);
  return errno == ERANGE && std::abs(x) < std::numeric_limits<double>::min();
}

namespace {

// A number below the smallest normal double (a p-value of 1e-312, say) would be written in a
// form every reader of dbbkit's files refuses (underflows above): it is written as 0, which
// is what it is at the precision a double holds. Non-finite numbers become null (nlohmann).
bool has_subnormal(const json& j) {
  if (j.is_number_float()) {
    const double x = j.get<double>();
    return x != 0 && std::abs(x) < std::numeric_limits<double>::min();
  }
  if (j.is_structured()) {
    for (const json& e : j)
      if (has_subnormal(e)) return true;
  }
  return false;
}

void flush_subnormal(json& j) {
  if (j.is_number_float()) {
    const double x = j.get<double>();
    if (x != 0 && std::abs(x) < std::numeric_limits<double>::min()) j = 0.0;
  } else if (j.is_structured()) {
    for (json& e : j) flush_subnormal(e);
  }
}

}  // namespace

std::string dump_json(const json& j, int indent) {
  if (has_subnormal(j)) {
    json flushed = j;
    flush_subnormal(flushed);
    return flushed.dump(indent, ' ', false, json::error_handler_t::replace);
  }
  return j.dump(indent, ' ', false, json::error_handler_t::replace);
}

namespace {

std::string line_column(const std::string& text, std::size_t byte) {
  std::size_t line = 1, col = 1;
  for (std::size_t i = 0; i < byte && i < text.size(); ++i) {
    if (text[i] == '\n') {
      ++line;
      col = 1;
    } else {
      ++col;
    }
  }
  return "line " + std::to_string(line) + ", column " + std::to_string(col);
}

std::string type_name(const json& v) {
  if (v.is_number()) return "a number";
  if (v.is_string()) return "a string";
  if (v.is_object()) return "an object";
  if (v.is_array()) return "a list";
  if (v.is_boolean()) return "true/false";
  if (v.is_null()) return "null";
  return "a value of another type";
}

// The optimal string alignment distance (Levenshtein's with a swap of two neighbours as one
// edit: 'stpo' is one from 'stop'), for pointing at a misspelt key.
std::size_t edit_distance(const std::string& a, const std::string& b) {
  std::vector<std::vector<std::size_t>> d(a.size() + 1, std::vector<std::size_t>(b.size() + 1));
  for (std::size_t i = 0; i <= a.size(); ++i) d[i][0] = i;
  for (std::size_t j = 0; j <= b.size(); ++j) d[0][j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i) {
    for (std::size_t j = 1; j <= b.size(); ++j) {
      d[i][j] = std::min(
          {d[i - 1][j] + 1, d[i][j - 1] + 1, d[i - 1][j - 1] + (a[i - 1] == b[j - 1] ? 0 : 1)});
      if (i > 1 && j > 1 && a[i - 1] == b[j - 2] && a[i - 2] == b[j - 1])
        d[i][j] = std::min(d[i][j], d[i - 2][j - 2] + 1);
    }
  }
  return d[a.size()][b.size()];
}

// Whether `given` may be `key` misspelt: the same but for case, or within one edit of a key of
// up to five characters, two of a longer one. Keys of one or two characters (L, H, dx, ez) are
// all within two edits of each other: only a change of case is taken for them.
bool misspelling_of(const std::string& given, const std::string& key) {
  if (given == key) return false;
  if (given.size() == key.size() &&
      std::equal(given.begin(), given.end(), key.begin(), [](char x, char y) {
        return std::tolower(static_cast<unsigned char>(x)) ==
               std::tolower(static_cast<unsigned char>(y));
      }))
    return true;
  if (key.size() <= 2 || given.size() > 2 * key.size() + 2) return false;
  return edit_distance(given, key) <= (key.size() <= 5 ? 1u : 2u);
}

}  // namespace

namespace {

// The byte at which the key token number `index` (0-based, in the order of the text) starts:
// a key is a string followed by a colon. The parser reports keys in this order.
std::size_t key_token_position(const std::string& text, std::size_t index) {
  std::size_t count = 0;
  for (std::size_t i = 0; i < text.size(); ++i) {
    if (text[i] != '"') continue;
    const std::size_t start = i;
    for (++i; i < text.size() && text[i] != '"'; ++i) {
      if (text[i] == '\\') ++i;
    }
    std::size_t j = i + 1;
    while (j < text.size() &&
           (text[j] == ' ' || text[j] == '\t' || text[j] == '\n' || text[j] == '\r'))
      ++j;
    if (j < text.size() && text[j] == ':' && count++ == index) return start;
  }
  return 0;
}

// Where the parser stands: for each open container, the key being read (an object) or the
// number of elements read (a list).
struct Frame {
  bool object = true;
  std::string key;
  std::size_t elements = 0;
  std::set<std::string> keys;
};

std::string frames_path(const std::vector<Frame>& frames, std::size_t depth) {
  std::string path;
  for (std::size_t i = 0; i < depth && i < frames.size(); ++i) {
    const Frame& f = frames[i];
    if (f.object) {
      path += (path.empty() ? "" : ".") + f.key;
    } else {
      path += "[" + std::to_string(f.elements) + "]";
    }
  }
  return path;
}

// The SAX pass of parse_json: the depth and the first key given twice, with its path.
struct Checker {
  const std::string& source;
  std::vector<Frame> frames;
  std::size_t keys_seen = 0;
  std::optional<std::size_t> duplicate_token;
  std::string duplicate_path;

  void deep_check() const {
    if (frames.size() > limits::kMaxJsonDepth) {
      throw InputError(source, frames_path(frames, frames.size()),
                       "nested deeper than " + std::to_string(limits::kMaxJsonDepth) +
                           " levels (docs/formats.md, \"Limits\")");
    }
  }
  bool value() {
    deep_check();
    if (!frames.empty() && !frames.back().object) ++frames.back().elements;
    return true;
  }
  bool null() { return value(); }
  bool boolean(bool) { return value(); }
  bool number_integer(json::number_integer_t) { return value(); }
  bool number_unsigned(json::number_unsigned_t) { return value(); }
  bool number_float(json::number_float_t, const json::string_t&) { return value(); }
  bool string(json::string_t&) { return value(); }
  bool binary(json::binary_t&) { return value(); }
  bool start(bool object) {
    deep_check();
    frames.push_back(Frame{object, "", 0, {}});
    return true;
  }
  bool start_object(std::size_t) { return start(true); }
  bool start_array(std::size_t) { return start(false); }
  bool end() {
    if (!frames.empty()) frames.pop_back();
    if (!frames.empty() && !frames.back().object) ++frames.back().elements;
    return true;
  }
  bool end_object() { return end(); }
  bool end_array() { return end(); }
  bool key(json::string_t& key) {
    deep_check();
    if (!frames.empty()) {
      frames.back().key = key;
      if (!frames.back().keys.insert(key).second && !duplicate_token) {
        duplicate_token = keys_seen;
        duplicate_path = frames_path(frames, frames.size());
      }
    }
    ++keys_seen;
    return true;
  }
  template <typename Exception>
  bool parse_error(std::size_t, const std::string&, const Exception& e) {
    throw e;
  }
};

}  // namespace

json parse_json(const std::string& text, const std::string& source) {
  if (text.find_first_not_of(" \t\r\n") == std::string::npos) {
    throw InputError(source, "", "the file is empty");
  }
  // nlohmann's parser reads a NUL byte as the end of the input: what follows would be ignored.
  if (const std::size_t nul = text.find('\0'); nul != std::string::npos)
    throw InputError(source, line_column(text, nul), "a NUL byte: not JSON text");
  if (text.size() > limits::kMaxJsonBytes) {
    throw InputError(source, "",
                     "more than the " + std::to_string(limits::kMaxJsonBytes >> 20) +
                         " MiB of JSON dbbkit reads from one input (docs/formats.md, \"Limits\")");
  }
  // A first pass through the SAX interface checks the depth and finds a key given twice, with
  // its path; the document is then parsed without a callback. (nlohmann's callback parser
  // searches the enclosing container for a discarded value at the end of every object: a list
  // of n objects took n^2 / 2 steps.)
  Checker checker{source, {}, 0, std::nullopt, ""};
  json j;
  try {
    json::sax_parse(text, &checker);
    j = json::parse(text);
  } catch (const json::parse_error& e) {
    std::string what = e.what();
    const auto pos = what.find("parse error");
    throw InputError(
        source, line_column(text, e.byte > 0 ? e.byte - 1 : 0),
        "not valid JSON (" + (pos == std::string::npos ? what : what.substr(pos)) + ")");
  } catch (const json::exception& e) {
    // e.g. out_of_range for a number beyond the range of a double: find the number.
    for (std::size_t i = 0; i < text.size(); ++i) {
      const char c = text[i];
      if (!(std::isdigit(static_cast<unsigned char>(c)) || c == '-') ||
          (i > 0 && std::isalnum(static_cast<unsigned char>(text[i - 1]))))
        continue;
      char* end = nullptr;
      const double x = std::strtod(text.c_str() + i, &end);
      if (end != text.c_str() + i && std::isinf(x)) {
        throw InputError(source, line_column(text, i), "a number beyond the range of a double");
      }
      if (end > text.c_str() + i) i = static_cast<std::size_t>(end - text.c_str());
    }
    throw InputError(source, "", std::string("not valid JSON (") + e.what() + ")");
  } catch (const std::bad_alloc&) {
    throw InputError(source, "",
                     "not enough memory to read the file (parsing JSON takes about 20 times its "
                     "size)");
  }
  // A number below the smallest a double holds is read as 0 or a denormal: refused, not
  // silently taken for zero. Number tokens outside strings are checked when the text has an
  // exponent at all.
  if (text.find_first_of("eE") != std::string::npos) {
    bool in_string = false;
    for (std::size_t i = 0; i < text.size(); ++i) {
      const char c = text[i];
      if (in_string) {
        if (c == '\\')
          ++i;
        else if (c == '"')
          in_string = false;
        continue;
      }
      if (c == '"') {
        in_string = true;
        continue;
      }
      if (c == '-' || (c >= '0' && c <= '9')) {
        std::size_t end = i;
        while (end < text.size() && (std::isdigit(static_cast<unsigned char>(text[end])) ||
                                     std::strchr("+-.eE", text[end])))
          ++end;
        if (underflows(text.substr(i, end - i))) {
          throw InputError(source, line_column(text, i),
                           "the number " + text.substr(i, std::min<std::size_t>(end - i, 40)) +
                               " is below the smallest a double holds (it would be read as 0)");
        }
        i = end - 1;
      }
    }
  }
  if (checker.duplicate_token) {
    throw InputError(source,
                     line_column(text, key_token_position(text, *checker.duplicate_token)) +
                         ", key " + quote_value(checker.duplicate_path, 200),
                     "the key appears twice in one object");
  }
  return j;
}

ObjectReader::ObjectReader(const json& value, std::string source, std::string path)
    : value_(value), source_(std::move(source)), path_(std::move(path)) {
  if (!value_.is_object()) {
    throw InputError(source_, path_.empty() ? "top level" : path_,
                     "expected an object {...}, found " + type_name(value_));
  }
}

std::string ObjectReader::key_path(const std::string& key) const {
  return path_.empty() ? key : path_ + "." + key;
}

void ObjectReader::fail(const std::string& key, const std::string& what) const {
  throw InputError(source_, key_path(key), what);
}

bool ObjectReader::has(const std::string& key) const { return value_.contains(key); }

ObjectReader& ObjectReader::allow(std::initializer_list<const char*> keys) {
  for (const char* k : keys) allowed_.insert(k);
  return *this;
}

const json& ObjectReader::required(const std::string& key) {
  asked_.insert(key);
  if (!value_.contains(key)) {
    // A key of the object that is no key it may hold (declared, or asked for so far) and is
    // close to the one missing.
    for (auto it = value_.begin(); it != value_.end(); ++it) {
      if (!asked_.count(it.key()) && !allowed_.count(it.key()) && misspelling_of(it.key(), key))
        fail(key,
             "required key is missing (is " + quote_value(it.key()) + " a misspelling of it?)");
    }
    // With the object's keys declared: a key it holds that is none of them is named beside the
    // missing one (a misspelling too far for the test above: "yy" for "y", "park" for "park_deg").
    if (!allowed_.empty()) {
      for (auto it = value_.begin(); it != value_.end(); ++it) {
        if (allowed_.count(it.key())) continue;
        std::string keys;
        for (const std::string& k : allowed_) keys += (keys.empty() ? "" : ", ") + k;
        fail(key, "required key is missing, and " + quote_value(it.key()) +
                      " is no key of this object (its keys: " + keys + "): misspelt?");
      }
    }
    fail(key, "required key is missing");
  }
  used_.insert(key);
  return value_.at(key);
}

const json* ObjectReader::optional(const std::string& key) {
  asked_.insert(key);
  if (!value_.contains(key)) return nullptr;
  used_.insert(key);
  return &value_.at(key);
}

double ObjectReader::number(const std::string& key) {
  return as_number(required(key), source_, key_path(key));
}

std::optional<double> ObjectReader::optional_number(const std::string& key) {
  const json* v = optional(key);
  if (!v) return std::nullopt;
  return as_number(*v, source_, key_path(key));
}

int ObjectReader::integer(const std::string& key) {
  return as_integer(required(key), source_, key_path(key));
}

std::optional<int> ObjectReader::optional_integer(const std::string& key) {
  const json* v = optional(key);
  if (!v) return std::nullopt;
  return as_integer(*v, source_, key_path(key));
}

std::string ObjectReader::string(const std::string& key) {
  return as_string(required(key), source_, key_path(key));
}

std::optional<std::string> ObjectReader::optional_string(const std::string& key) {
  const json* v = optional(key);
  if (!v) return std::nullopt;
  return as_string(*v, source_, key_path(key));
}

ObjectReader ObjectReader::object(const std::string& key) {
  return ObjectReader(required(key), source_, key_path(key));
}

void ObjectReader::finish() const {
  for (auto it = value_.begin(); it != value_.end(); ++it) {
    if (used_.count(it.key())) continue;
    // The key it may stand for: one the object may hold and does not.
    std::set<std::string> absent = allowed_;
    absent.insert(asked_.begin(), asked_.end());
    for (const std::string& k : absent) {
      if (!value_.contains(k) && misspelling_of(it.key(), k))
        fail(it.key(), "unknown key (a misspelling of " + quote_value(k) + "?)");
    }
    fail(it.key(), "unknown key (misspelt?)");
  }
}

double as_number(const json& v, const std::string& source, const std::string& path) {
  if (!v.is_number()) throw InputError(source, path, "expected a number, found " + type_name(v));
  const double x = v.get<double>();
  if (!std::isfinite(x)) throw InputError(source, path, "not a finite number");
  return x;
}

int as_integer(const json& v, const std::string& source, const std::string& path) {
  const double x = as_number(v, source, path);
  if (x != std::floor(x) || std::abs(x) > 2e9)
    throw InputError(source, path, "expected an integer");
  return static_cast<int>(x);
}

std::string as_string(const json& v, const std::string& source, const std::string& path) {
  if (!v.is_string()) throw InputError(source, path, "expected a string, found " + type_name(v));
  const std::string& s = v.get_ref<const std::string&>();
  // Text is data (user_text.hpp): what no writer could carry is refused where it is read.
  if (const auto p = text_problem(s, limits::kMaxTextBytes))
    throw InputError(source, path, quote_value(s) + ": " + *p);
  return s;
}

std::vector<double> read_numbers(const nlohmann::json& v, const std::string& source,
                                 const std::string& path) {
  if (!v.is_array()) throw InputError(source, path, "expected a list of numbers");
  std::vector<double> out;
  for (size_t i = 0; i < v.size(); ++i)
    out.push_back(as_number(v[i], source, path + "[" + std::to_string(i) + "]"));
  return out;
}

}  // namespace dbbkit::io
