#pragma once
// Strict reading of a JSON object's keys and values: internal to the library's readers (the
// installed json_reader.hpp reads and parses a file).

#include <initializer_list>
#include <nlohmann/json.hpp>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "dbbkit/io/json_reader.hpp"

namespace dbbkit::io {

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
