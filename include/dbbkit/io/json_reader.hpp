#pragma once
// Strict JSON reading: syntax errors name line and column, duplicate keys and
// unknown keys are errors, every type error names the key path.

#include <initializer_list>
#include <nlohmann/json.hpp>
#include <optional>
#include <set>
#include <string>
#include <vector>

namespace dbbkit::io {

// Reads a whole file; throws InputError(path, "", ...) when it cannot be read or is longer
// than limits::kMaxInputBytes.
std::string read_text_file(const std::string& path);
// At most max_bytes + a block of it (a longer one is cut there: the caller refuses it).
std::string read_text_file(const std::string& path, std::size_t max_bytes);
// A JSON input: read no further than one byte beyond limits::kMaxJsonBytes (parse_json refuses
// it then), so a pipe of endless JSON costs no more.
std::string read_json_file(const std::string& path);

// A decimal number as people write it: optional sign, digits with an optional
// point, an optional exponent (1.5, -0.2, 3e-3). No hexadecimal, no "inf" or "nan",
// no white space. Sets `out` and returns true when `text` is one and finite.
bool parse_decimal(const std::string& text, double& out);
// Whether a decimal number is one whose digits are not all zero but which is below the
// smallest normal double (1e-400): parse_decimal refuses it, and its message says why.
bool underflows(const std::string& text);

// JSON text as dbbkit writes it (indented by `indent`): a string that is not valid UTF-8 (a
// file name of other bytes) is written with U+FFFD in place of its invalid bytes, never a
// failure of the writer.
std::string dump_json(const nlohmann::json& j, int indent = 2);

// Parses JSON; a syntax error or a repeated key throws InputError naming the line.
nlohmann::json parse_json(const std::string& text, const std::string& source);

// Reads the keys of one JSON object, remembering which were used, so that
// finish() can reject the keys nobody asked for (typos must not pass).
class ObjectReader {
 public:
  ObjectReader(const nlohmann::json& value, std::string source, std::string path);

  bool has(const std::string& key) const;
  // The keys the object may hold, declared before they are read where some are alike (start,
  // stop, step): a missing key's suggestion ("is 'stpo' a misspelling of it?") is never one of
  // them, and an unknown key's is one of them that is absent. Without it the keys asked for so
  // far stand in.
  ObjectReader& allow(std::initializer_list<const char*> keys);
  const nlohmann::json& required(const std::string& key);
  const nlohmann::json* optional(const std::string& key);

  double number(const std::string& key);
  std::optional<double> optional_number(const std::string& key);
  int integer(const std::string& key);
  std::optional<int> optional_integer(const std::string& key);
  std::string string(const std::string& key);
  std::optional<std::string> optional_string(const std::string& key);
  ObjectReader object(const std::string& key);

  std::string key_path(const std::string& key) const;
  const std::string& source() const { return source_; }
  [[noreturn]] void fail(const std::string& key, const std::string& what) const;
  // Throws on the first key that was never read.
  void finish() const;

 private:
  const nlohmann::json& value_;
  std::string source_, path_;
  std::set<std::string> used_;   // present keys that were read
  std::set<std::string> asked_;  // every key asked for (required, optional), present or not
  std::set<std::string> allowed_;
};

// Value conversions with the key path in the error.
double as_number(const nlohmann::json& v, const std::string& source, const std::string& path);
int as_integer(const nlohmann::json& v, const std::string& source, const std::string& path);
std::string as_string(const nlohmann::json& v, const std::string& source, const std::string& path);
// A list of numbers; throws InputError(source, path[i]) at the first that is not one.
std::vector<double> read_numbers(const nlohmann::json& v, const std::string& source,
                                 const std::string& path);

}  // namespace dbbkit::io
