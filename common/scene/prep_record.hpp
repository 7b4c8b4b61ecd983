// A prep directory's prep.json as the scene reads it (internal to common/scene): bounded in size
// before it is read, parsed without exceptions.
#pragma once

#include <cstdint>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>
#include <system_error>

#include "prep/prep.hpp"

namespace palp::scene_detail {

// prep.json is a few KiB; a larger one is not read.
inline constexpr std::uintmax_t kMaxPrepJsonBytes = std::uintmax_t{1} << 20;

// dir/prep.json parsed; a discarded json and *why ("no prep.json", "prep.json over 1 MiB",
// "prep.json unreadable") when it is missing, too large, or not a JSON object.
inline nlohmann::json read_prep_record(const std::filesystem::path& dir, std::string* why) {
  const std::filesystem::path path = dir / kPrepJsonFile;
  std::error_code ec;
  const std::uintmax_t bytes = std::filesystem::file_size(path, ec);
  const auto fail = [&](const char* reason) {
    if (why) *why = reason;
    return nlohmann::json(nlohmann::json::value_t::discarded);
  };
  if (ec) return fail("no prep.json");
  if (bytes > kMaxPrepJsonBytes) return fail("prep.json over 1 MiB");
  std::ifstream in(path);
  nlohmann::json json = nlohmann::json::parse(in, nullptr, /*allow_exceptions=*/false);
  if (json.is_discarded() || !json.is_object()) return fail("prep.json unreadable");
  return json;
}

}  // namespace palp::scene_detail
