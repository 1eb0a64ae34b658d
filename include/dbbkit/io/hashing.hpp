#pragma once
// SHA-256 (FIPS 180-4) of the input files a report names, so that a report says exactly
// which files it came from.

#include <string>

namespace dbbkit::io {

// SHA-256 of bytes, as 64 lower-case hex digits.
std::string sha256_hex(const std::string& bytes);
// SHA-256 of a file's bytes; throws InputError when the file cannot be read.
std::string sha256_file(const std::string& path);

}  // namespace dbbkit::io
