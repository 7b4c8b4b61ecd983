// PrepOutputGuard: what an unfinished prep removes (temporary files always; outputs and the
// directories only when this run created them) and what it never touches.
#include "prep/output_guard.hpp"

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "base/errors.hpp"

namespace palp {
namespace {

namespace fs = std::filesystem;

class OutputGuardTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("palp_output_guard_test_" + std::to_string(::getpid()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  fs::path dir_;
};

void touch(const fs::path& path) {
  std::ofstream(path) << "x";
}

TEST_F(OutputGuardTest, UncommittedRunRemovesWhatItCreatedParentsIncluded) {
  const fs::path out = dir_ / "a" / "b" / "out";
  {
    PrepOutputGuard guard(out, {"m"});
    fs::create_directories(out);
    touch(out / "m.partial");
    touch(out / "m.tmp-1-0");
    touch(out / "m");
  }
  EXPECT_FALSE(fs::exists(dir_ / "a"));
  EXPECT_TRUE(fs::exists(dir_));
}

TEST_F(OutputGuardTest, ExistingDirectoryKeepsItsFilesAndLosesOnlyTheTemporaries) {
  const fs::path out = dir_ / "out";
  fs::create_directories(out);
  touch(out / "m");
  {
    PrepOutputGuard guard(out, {"m"});
    touch(out / "m.partial");
    touch(out / "m.tmp-1-0");
  }
  EXPECT_FALSE(fs::exists(out / "m.partial"));
  EXPECT_FALSE(fs::exists(out / "m.tmp-1-0"));
  EXPECT_TRUE(fs::exists(out / "m"));
}

TEST_F(OutputGuardTest, NewDirectoryHoldingOtherFilesStays) {
  const fs::path out = dir_ / "out";
  {
    PrepOutputGuard guard(out, {"m"});
    fs::create_directories(out);
    touch(out / "m");
    touch(out / "someone_elses");
    touch(out / "m.backup");
  }
  EXPECT_FALSE(fs::exists(out / "m"));
  EXPECT_TRUE(fs::exists(out / "someone_elses"));
  EXPECT_TRUE(fs::exists(out / "m.backup"));
}

TEST_F(OutputGuardTest, CommittedRunKeepsEverything) {
  const fs::path out = dir_ / "out";
  {
    PrepOutputGuard guard(out, {"m"});
    fs::create_directories(out);
    touch(out / "m");
    guard.commit();
  }
  EXPECT_TRUE(fs::exists(out / "m"));
}

// The names of a label map's structures are known only once it is read.
TEST_F(OutputGuardTest, NamesAddedLaterAreCleanedUpToo) {
  const fs::path out = dir_ / "new";
  {
    PrepOutputGuard guard(out, {"m"});
    fs::create_directories(out);
    touch(out / "m");
    std::vector<std::string> names;
    for (int i = 0; i < 300; ++i)
      names.push_back(std::string("s").append(std::to_string(i)) + ".nii.gz");
    guard.add_names(names);
    touch(out / "s0.nii.gz");
    touch(out / "s299.nii.gz.partial.nii.gz");
  }
  EXPECT_FALSE(fs::exists(out));
  const fs::path existing = dir_ / "existing";
  fs::create_directories(existing);
  touch(existing / "liver.nii.gz");
  {
    PrepOutputGuard guard(existing, {"m"});
    guard.add_names({"liver.nii.gz"});
    touch(existing / "liver.nii.gz.partial.nii.gz");
  }
  EXPECT_TRUE(fs::exists(existing / "liver.nii.gz"));
  EXPECT_FALSE(fs::exists(existing / "liver.nii.gz.partial.nii.gz"));
  PrepOutputGuard guard(existing, {});
  EXPECT_THROW(guard.add_names(std::vector<std::string>(600, "x")), Error);
  guard.commit();
}

TEST_F(OutputGuardTest, TrailingSeparatorNamesTheSameDirectory) {
  const fs::path out = (dir_ / "x" / "out").string() + "/";
  {
    PrepOutputGuard guard(out, {});
    fs::create_directories(out);
  }
  EXPECT_FALSE(fs::exists(dir_ / "x"));
}

}  // namespace
}  // namespace palp
