#pragma once
// Writing results without losing data: to a temporary file beside the target,
// renamed into place only when complete; an output path that names an input is refused.

#include <string>
#include <vector>

namespace dbbkit::io {

// "-" or "" writes to stdout. Throws InputError when `path` is one of `inputs`
// or cannot be written.
void write_output(const std::string& path, const std::string& content,
                  const std::vector<std::string>& inputs = {});

}  // namespace dbbkit::io
