#pragma once
// Strict JSON reading: syntax errors name line and column, duplicate keys and
// unknown keys are errors, every type error names the key path.

#include <nlohmann/json.hpp>
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

}  // namespace dbbkit::io
