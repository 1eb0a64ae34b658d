#include "dbbkit/io/text.hpp"

#include <iomanip>
#include <sstream>

namespace dbbkit::io {

std::string fmt_num(double x, int digits) {
  std::ostringstream s;
  s << std::setprecision(digits) << x;
  return s.str();
}

std::string fmt_opt(const std::optional<double>& x, int digits) {
  return x ? fmt_num(*x, digits) : "--";
}

}  // namespace dbbkit::io
