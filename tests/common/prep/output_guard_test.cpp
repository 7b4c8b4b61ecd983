// PrepOutputGuard: what an unfinished prep removes (temporary files always; outputs and the
// directories only when this run created them) and what it never touches.
#include "prep/output_guard.hpp"

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>

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
