// Whole-file writes through a renamed partial file: see file_replace.hpp.
#include "base/file_replace.hpp"

#include <filesystem>
#include <fstream>
#include <system_error>

#include "base/errors.hpp"

namespace palp {

void replace_file(const std::string& path, std::string_view text) {
  const std::string partial = path + ".partial";
  std::error_code ec;
  {
    std::ofstream out(partial, std::ios::binary | std::ios::trunc);
    out.write(text.data(), static_cast<std::streamsize>(text.size()));
    out.close();
    if (!out) {
      std::filesystem::remove(partial, ec);
      throw Error(path + ": cannot be written");
    }
  }
  std::filesystem::rename(partial, path, ec);
  if (ec) {
    std::error_code ignored;
    std::filesystem::remove(partial, ignored);
    throw Error(path + ": cannot be written: " + ec.message());
  }
}

}  // namespace palp
