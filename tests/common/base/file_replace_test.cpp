// replace_file: the whole text or nothing, under the final name only after the rename; a path
// that cannot be written throws naming it and leaves no partial file behind.
#include "base/file_replace.hpp"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "base/errors.hpp"
#include "support/io_test_util.hpp"

namespace palp {
namespace {

namespace fs = std::filesystem;

std::string read_all(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

TEST(ReplaceFile, WritesAndReplacesTheWholeText) {
  testing::TempDir dir;
  const std::string path = (dir.path() / "out.csv").string();
  replace_file(path, "first\n");
  EXPECT_EQ(read_all(path), "first\n");
  const std::string binary("a\0b\r\n", 5);
  replace_file(path, binary);  // shorter than before: nothing of the old text remains
  EXPECT_EQ(read_all(path), binary);
  EXPECT_FALSE(fs::exists(path + ".partial"));
}

TEST(ReplaceFile, AnUnwritablePathThrowsAndLeavesNoPartial) {
  testing::TempDir dir;
  const std::string missing = (dir.path() / "no-such-dir" / "out.json").string();
  EXPECT_THROW(replace_file(missing, "x"), Error);
  // a directory where the file should be: the partial is written, the rename fails
  const fs::path taken = dir.path() / "taken";
  fs::create_directories(taken / "inside");
  try {
    replace_file(taken.string(), "x");
    FAIL() << "wrote over a directory";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find(taken.string()), std::string::npos) << e.what();
  }
  EXPECT_FALSE(fs::exists(taken.string() + ".partial"));
  EXPECT_TRUE(fs::is_directory(taken / "inside"));
}

}  // namespace
}  // namespace palp
