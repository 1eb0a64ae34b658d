#pragma once
// One line of a part program as the tests read it back: its code (the Heidenhain block number
// taken off), its comment, its words, and the installation a comment opens.
#include <sstream>
#include <string>
#include <vector>

#include "dbbkit/io/program_io.hpp"

namespace dbbkit::test {

struct ProgramLine {
  std::string code, comment;
  std::vector<std::string> words;
};

inline ProgramLine program_line(const std::string& line, io::Dialect dialect) {
  ProgramLine l;
  l.code = line;
  if (dialect == io::Dialect::kIso) {
    const size_t open = l.code.find('(');
    if (open != std::string::npos) {
      l.comment = l.code.substr(open + 1, l.code.find(')', open) - open - 1);
      l.code = l.code.substr(0, open);
    }
  } else {
    const size_t semi = l.code.find(';');
    if (semi != std::string::npos) {
      l.comment = l.code.substr(semi + 1);
      l.code = l.code.substr(0, semi);
    }
    if (dialect == io::Dialect::kHeidenhain) {
      std::istringstream first(l.code);
      int number = -1;
      first >> number;  // the block number
      std::getline(first, l.code);
      l.code.erase(0, l.code.find_first_not_of(' '));
    }
  }
  std::istringstream words(l.code);
  for (std::string t; words >> t;) l.words.push_back(t);
  return l;
}

// The installation a comment "installation ID (k of n): ..." opens, or empty.
inline std::string opened_installation(const std::string& comment) {
  const std::string marker = "installation ";
  if (comment.find(marker) == std::string::npos || comment.find(" of ") == std::string::npos)
    return "";
  std::istringstream c(comment.substr(comment.find(marker) + marker.size()));
  std::string id;
  c >> id;
  return id;
}

}  // namespace dbbkit::test
