#pragma once
// Exceptions of dbbkit. Bad input (a file, a key, a value) is an InputError;
// numerical outcomes such as rank loss are statuses of a Summary, never exceptions.

#include <stdexcept>
#include <string>

namespace dbbkit {

// Bad input: `source` names the file (or "design" for an object built in code),
// `where` the line or key ("line 12", "installations[3].direction"), `detail` what is wrong.
// Each part is kept as a terminal may show it: control characters as escapes (line feeds and
// tabs kept), and cut after a few hundred bytes (a path 1000, a key 300, the detail 2000).
class InputError : public std::runtime_error {
 public:
  InputError(std::string source, std::string where, std::string detail);

  const std::string& source() const { return source_; }
  const std::string& where() const { return where_; }
  const std::string& detail() const { return detail_; }
  const char* what() const noexcept override { return what_.c_str(); }

  // The same error attributed to another source (e.g. the file a design was read from).
  InputError with_source(const std::string& source) const;

 private:
  std::string source_, where_, detail_, what_;
};

}  // namespace dbbkit
