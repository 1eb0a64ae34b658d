#pragma once
// The cells of a comma-separated file as dbbkit's readers take them (measurements, poses): lines
// ended by LF, CR LF or a CR alone, cells trimmed, numbers in decimal notation, each refusal
// naming the line and the column. Internal to io.

#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <sstream>
#include <string>
#include <vector>

#include "dbbkit/error.hpp"
#include "dbbkit/io/json_reader.hpp"
#include "dbbkit/user_text.hpp"

namespace dbbkit::io::csv {

// The text with every line end made LF.
inline std::string lf_lines(const std::string& text) {
  std::string lines;
  lines.reserve(text.size());
  for (std::size_t i = 0; i < text.size(); ++i) {
    if (text[i] == '\r') {
      if (i + 1 < text.size() && text[i + 1] == '\n') continue;
      lines += '\n';
    } else {
      lines += text[i];
    }
  }
  return lines;
}

inline std::string trim(const std::string& s) {
  const auto b = s.find_first_not_of(" \t");
  if (b == std::string::npos) return "";
  const auto e = s.find_last_not_of(" \t");
  return s.substr(b, e - b + 1);
}

inline std::vector<std::string> split(const std::string& line) {
  std::vector<std::string> out;
  std::string cell;
  std::istringstream s(line);
  while (std::getline(s, cell, ',')) out.push_back(trim(cell));
  if (!line.empty() && line.back() == ',') out.emplace_back();
  return out;
}

struct Cell {
  const std::string& source;
  int line;
  const std::string& column;
  const std::string& text;

  [[noreturn]] void fail(const std::string& what) const {
    throw InputError(source, "line " + std::to_string(line) + ", column " + column, what);
  }
  double number() const {
    if (text.empty()) fail("empty value");
    double x = 0;
    if (!parse_decimal(text, x)) {
      const bool spelled_number = text.find_first_of("0123456789") != std::string::npos ||
                                  text == "nan" || text == "NaN" || text == "inf" ||
                                  text == "-inf" || text == "+inf";
      if (underflows(text))
        fail(quote_value(text) + " is below the smallest number a double holds");
      fail(quote_value(text) + " is not " +
           (spelled_number ? "a finite number in decimal notation" : "a number"));
    }
    return x;
  }
  int integer() const {
    if (text.empty()) fail("empty value");
    char* end = nullptr;
    errno = 0;
    const long x = std::strtol(text.c_str(), &end, 10);
    if (end != text.c_str() + text.size()) fail(quote_value(text) + " is not an integer");
    if (errno == ERANGE || std::abs(x) > 2000000000L)
      fail(quote_value(text) + " is an integer beyond +-2000000000, the most this column takes");
    return static_cast<int>(x);
  }
};

}  // namespace dbbkit::io::csv
