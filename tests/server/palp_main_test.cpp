// The palp command line as a user meets it: help on every command, one-line errors with the
// documented exit codes, and the phantom and prep commands end to end.
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "io/ct_io.hpp"
#include "io/phantom.hpp"
#include "support/cli_test_util.hpp"

namespace palp {
namespace {

namespace fs = std::filesystem;

// palp with a private scene cache in this test's directory; stderr together with stdout.
testing::CliOutcome run_palp(const std::string& args) {
  return testing::run_palp_cli(args, testing::shared_cli_dir() / "cache");
}

class PalpCli : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("palp_cli_test_" + std::to_string(::getpid()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  fs::path dir_;
};

TEST_F(PalpCli, HelpOnEveryCommand) {
  for (const char* args : {"--help", "phantom --help", "prep --help", "prep -h"}) {
    const auto out = run_palp(args);
    EXPECT_EQ(out.exit_code, 0) << args;
    EXPECT_NE(out.output.find("usage: palp"), std::string::npos) << args;
  }
  EXPECT_EQ(run_palp("").exit_code, 2);
  // prep says what it will read, absolute and ../ data-file paths included, and the whole text
  // (longer than its old buffer) is there.
  const auto prep = run_palp("prep --help");
  EXPECT_NE(prep.output.find("What prep reads: INPUT; for a .mhd or .nhdr header also the data"),
            std::string::npos)
      << prep.output;
  EXPECT_NE(prep.output.find("an absolute path or lead out of the header's directory with ../"),
            std::string::npos)
      << prep.output;
  EXPECT_NE(prep.output.find("  -h, --help"), std::string::npos) << prep.output;
}

TEST_F(PalpCli, UsageMistakesExitWithTwoAndOneLine) {
  for (const char* args :
       {"frobnicate", "prep", "prep x", "prep x --out", "phantom cube",
        "prep phantom:cube --out d --band abc", "phantom cube --out f --dims 1x2",
        "prep phantom:cube --out d --bogus", "prep phantom:cube --out d --surface voxel",
        "prep phantom:cube --out d --skin-hu x", "phantom cube --out f --metal",
        "phantom torso --out f --contrast venous", "phantom torso --out f --arms 3",
        "phantom torso --out f --aorta-hu hot"}) {
    const auto out = run_palp(args);
    EXPECT_EQ(out.exit_code, 2) << args << ": " << out.output;
    EXPECT_EQ(testing::count_lines(out.output), 1) << args << ": " << out.output;
  }
}

TEST_F(PalpCli, BadInputsGiveOneLineErrorsAndExitOne) {
  const fs::path truncated = dir_ / "truncated.nii.gz";
  {
    std::ofstream f(truncated, std::ios::binary);
    const unsigned char gzip_start[] = {0x1f, 0x8b, 0x08, 0x00, 0, 0, 0, 0, 0, 0x03, 0x4b, 0x4c};
    f.write(reinterpret_cast<const char*>(gzip_start), sizeof gzip_start);
  }
  const fs::path empty_dir = dir_ / "empty";
  fs::create_directories(empty_dir);
  for (const std::string& input : {(dir_ / "missing.nii.gz").string(), truncated.string(),
                                   empty_dir.string(), std::string("phantom:nothing")}) {
    const auto out = run_palp("prep " + input + " --out " + (dir_ / "out").string());
    EXPECT_NE(out.exit_code, 0) << input;
    EXPECT_EQ(testing::count_lines(out.output), 2)
        << input << ": " << out.output;  // banner + the error
    EXPECT_NE(out.output.find("palp"), std::string::npos);
  }
}

TEST_F(PalpCli, PhantomThenPrepThenCachedPrep) {
  const fs::path ct = dir_ / "cube.nii.gz";
  const auto made = run_palp("phantom cube --out " + ct.string() + " --dims 60x60x60");
  ASSERT_EQ(made.exit_code, 0) << made.output;
  ASSERT_TRUE(fs::exists(ct));
  const std::string prep = "prep " + ct.string() + " --out " + (dir_ / "prep").string();
  const auto first = run_palp(prep);
  ASSERT_EQ(first.exit_code, 0) << first.output;
  for (const char* stage : {"read CT", "body mask", "d_surf", "d_bone", "total"}) {
    EXPECT_NE(first.output.find(stage), std::string::npos) << stage << "\n" << first.output;
  }
  for (const char* file :
       {"body.nii.gz", "bone.nii.gz", "d_surf.nii.gz", "d_bone.nii.gz", "prep.json"}) {
    EXPECT_TRUE(fs::exists(dir_ / "prep" / file)) << file;
  }
  const auto second = run_palp(prep);
  ASSERT_EQ(second.exit_code, 0);
  EXPECT_NE(second.output.find("cached"), std::string::npos) << second.output;
  const auto forced = run_palp(prep + " --no-cache");
  EXPECT_EQ(forced.output.find("cached"), std::string::npos) << forced.output;
}

// The torso's options on the command line draw what make_phantom draws with them.
TEST_F(PalpCli, PhantomTorsoOptions) {
  const fs::path ct = dir_ / "torso.nii.gz";
  const auto made = run_palp("phantom torso --out " + ct.string() +
                             " --dims 96x64x12 --contrast portal-venous --aorta-hu 300 --arms 2"
                             " --metal");
  ASSERT_EQ(made.exit_code, 0) << made.output;
  PhantomOptions o;
  o.dims = Index3{96, 64, 12};
  o.contrast = PhantomContrast::portal_venous;
  o.aorta_hu = 300.0;
  o.arms = 2;
  o.metal = true;
  EXPECT_TRUE(read_ct(ct.string()).data == make_phantom("torso", o).data);
}

TEST_F(PalpCli, PhantomTorsoStructures) {
  const fs::path ct = dir_ / "torso.nii.gz";
  const auto made =
      run_palp("phantom torso --out " + ct.string() + " --dims 96x64x12 --structures");
  ASSERT_EQ(made.exit_code, 0) << made.output;
  PhantomOptions o;
  o.dims = Index3{96, 64, 12};
  o.structures = true;
  const CtVolume read = read_ct(ct.string());
  EXPECT_TRUE(read.data == make_phantom("torso", o).data);
  o.structures = false;  // the slab's middle 24 mm hold the liver's edge lobe
  EXPECT_FALSE(read.data == make_phantom("torso", o).data);
}

}  // namespace
}  // namespace palp
