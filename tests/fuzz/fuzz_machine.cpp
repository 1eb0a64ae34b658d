// libFuzzer target: the machine file's reader (machine_io.hpp), then the file written back and
// read again. Bad input must end in InputError; any other exception or a crash is a bug.
#include <cstdint>
#include <string>

#include "dbbkit/error.hpp"
#include "dbbkit/io/json_reader.hpp"
#include "dbbkit/io/machine_io.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  try {
    const dbbkit::Machine m =
        dbbkit::io::machine_from_json(dbbkit::io::parse_json(text, "fuzz"), "fuzz");
    // What it writes, it reads back.
    const dbbkit::Machine again =
        dbbkit::io::machine_from_json(dbbkit::io::machine_to_json(m), "again");
    if (again.rotary.size() != m.rotary.size() || again.name != m.name) __builtin_trap();
  } catch (const dbbkit::InputError&) {
  }
  return 0;
}
