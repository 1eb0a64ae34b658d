#pragma once
// Reader of kit files, format `dbbkit.kit/1` (formats.md).

#include <nlohmann/json.hpp>
#include <string>

#include "dbbkit/kit.hpp"

namespace dbbkit::io {

inline constexpr const char* kKitFormat = "dbbkit.kit/1";

// Throws InputError naming the file and the key of the first problem. A machine the kit names by
// a relative path is read relative to `base_dir` (read_kit_file: the kit file's folder; empty:
// the working directory).
Kit read_kit_file(const std::string& path);
Kit kit_from_json(const nlohmann::json& j, const std::string& source,
                  const std::string& base_dir = "");
Kit kit_from_text(const std::string& text, const std::string& source,
                  const std::string& base_dir = "");

}  // namespace dbbkit::io
