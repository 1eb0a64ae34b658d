#pragma once
// Reader of machine files, format `dbbkit.machine/1` (formats.md, "Machine file").

#include <nlohmann/json.hpp>
#include <string>

#include "dbbkit/machine.hpp"

namespace dbbkit::io {

inline constexpr const char* kMachineFormat = "dbbkit.machine/1";

// Throws InputError naming the file and the key of the first problem.
Machine read_machine_file(const std::string& path);
Machine machine_from_json(const nlohmann::json& j, const std::string& source);
nlohmann::json machine_to_json(const Machine& m);

}  // namespace dbbkit::io
