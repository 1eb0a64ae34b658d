#include "dbbkit/io/output.hpp"

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <system_error>

#include "dbbkit/error.hpp"

namespace dbbkit::io {

namespace fs = std::filesystem;

void write_output(const std::string& path, const std::string& content, const std::vector<std::string>& inputs) {
  if (path.empty() || path == "-") {
    std::cout << content;
    std::cout.flush();
    return;
  }
  std::error_code ec;
  const fs::path target = fs::weakly_canonical(path, ec);
  for (const std::string& in : inputs) {
    std::error_code ec2;
    if (!ec && fs::weakly_canonical(in, ec2) == target && !ec2) {
      throw InputError(path, "", "the output would overwrite the input file " + in);
    }
  }
  const std::string tmp = path + ".tmp";
  {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    if (!out) throw InputError(path, "", "cannot open for writing");
    out << content;
    out.close();
    if (!out) {
      std::remove(tmp.c_str());
      throw InputError(path, "", "error while writing");
    }
  }
  fs::rename(tmp, path, ec);
  if (ec) {
    std::remove(tmp.c_str());
    throw InputError(path, "", "cannot move the finished file into place: " + ec.message());
  }
}

}  // namespace dbbkit::io
