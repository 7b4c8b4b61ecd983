// palpd --igtl-port against a client nobody here wrote: the OpenIGTLink library's own example
// receiver (ReceiveClient.cxx from Debian's openigtlink-examples, compiled unchanged in the test
// tree as igtl_example_receive_client). It prints every TRANSFORM it gets; each printed triple
// (PalpTool, PalpForce, PalpU) must be a tick palpd recorded (--record), placed by the CT's frame.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <limits>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

#include "interop/igtl_frame.hpp"
#include "io/ct_io.hpp"
#include "rt/recording.hpp"
#include "support/palpd_process.hpp"

namespace palp::interop {
namespace {

namespace fs = std::filesystem;
using Printed = std::array<std::array<double, 4>, 4>;

// The example prints each matrix as "=============", four rows "a, b, c, d", "=============".
std::vector<Printed> printed_matrices(const std::string& text) {
  std::vector<Printed> out;
  std::istringstream in(text);
  std::string line;
  while (std::getline(in, line)) {
    if (line != "=============") continue;
    Printed m{};
    bool ok = true;
    for (int r = 0; r < 4 && ok; ++r) {
      if (!std::getline(in, line)) ok = false;
      std::istringstream row(line);
      for (int c = 0; c < 4 && ok; ++c) {
        char comma = 0;
        if (!(row >> m[r][c])) ok = false;
        if (c < 3 && !(row >> comma)) ok = false;
      }
    }
    if (ok && std::getline(in, line) && line == "=============") out.push_back(m);
  }
  return out;
}

// Printed with 6 significant digits.
bool close_to(double printed, double exact) {
  return std::abs(printed - exact) <= 1e-5 * std::max(1.0, std::abs(exact)) + 1e-6;
}

bool matches(const Printed& p, const Matrix4& m) {
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c)
      if (!close_to(p[r][c], m[r][c])) return false;
  return true;
}

Matrix4 translation(const Vec3d& v) {
  Matrix4 m{};
  for (int i = 0; i < 4; ++i) m[i][i] = 1;
  m[0][3] = v.x, m[1][3] = v.y, m[2][3] = v.z;
  return m;
}

void check_storage(const std::string& orientation) {
  const fs::path dir = testing::shared_cli_dir() / ("igtl-" + orientation);
  fs::create_directories(dir);
  const fs::path ct = dir / "torso.nii.gz";
  ASSERT_EQ(testing::run_palp_cli("phantom torso --dims 64x48x24 --orientation " + orientation +
                                      " --out '" + ct.string() + "'",
                                  testing::shared_cli_dir() / "cache")
                .exit_code,
            0);
  const fs::path log = dir / "palpd.log", rec = dir / "run.palprec";
  const int port = testing::start_palpd("--scene '" + ct.string() +
                                            "' --device sim --port 0 --igtl-port 0 "
                                            "--no-realtime --duration 6 --record '" +
                                            rec.string() + "'",
                                        log);
  ASSERT_GT(port, 0) << testing::read_text(log);
  std::smatch match;
  const std::string started = testing::read_text(log);
  ASSERT_TRUE(
      std::regex_search(started, match, std::regex("OpenIGTLink on 127\\.0\\.0\\.1:([0-9]+)")))
      << started;
  const fs::path out = dir / "receiver.out";
  const std::string command = std::string("timeout 3 ") + IGTL_RECEIVE_CLIENT_PATH + " 127.0.0.1 " +
                              match[1].str() + " >'" + out.string() + "' 2>/dev/null";
  const int status = std::system(command.c_str());
  EXPECT_EQ(WEXITSTATUS(status), 124);  // it receives until killed
  ASSERT_TRUE(testing::wait_palpd_exit(log)) << testing::read_text(log);

  const std::vector<Printed> printed = printed_matrices(testing::read_text(out));
  const rt::Recording recording = rt::read_recording(rec.string());
  const Matrix4 frame = ras_from_scene(read_ct(ct.string()).grid);
  ASSERT_GE(printed.size(), 15u) << "fewer than 5 samples in 3 s";
  std::size_t missing = 0;  // ticks absent from the recording (its ring dropped them)
  for (std::size_t i = 1; i < recording.records.size(); ++i)
    missing += recording.records[i].seq - recording.records[i - 1].seq - 1;
  // palpd keeps the first tick it is offered at or after each 1/60 s step of loop time (steps
  // phase-locked to the first). A tick whose snapshot the network ring dropped (a loaded
  // machine) is never offered, so a kept tick can come late in its step and the next one early
  // in the following step: neighbours may be closer than 1/60 s, but any two samples two apart
  // are more than 1/60 s apart (t[k+2] >= step[k+2] >= step[k+1] + 1/60 > t[k] + 1/60).
  // Printed with 6 digits, a slow tool matches several ticks (and the sim's trajectory repeats):
  // each sample is given the earliest matching tick after the previous sample's and more than
  // 1/60 s after the one before that, which exists exactly when the samples obey that bound.
  constexpr std::int64_t kStepNs = 1'000'000'000 / 60;
  std::size_t unmatched = 0, spaced = 0, too_close = 0;
  std::int64_t last_t = std::numeric_limits<std::int64_t>::min() / 2, before_last_t = last_t;
  for (std::size_t i = 0; i + 3 <= printed.size(); i += 3) {
    bool any = false;
    std::int64_t found = -1;
    for (const rt::TickRecord& r : recording.records)
      if (matches(printed[i], ras_pose(frame, r.pose)) &&
          matches(printed[i + 1], translation(ras_vector(frame, r.force))) &&
          matches(printed[i + 2], translation(ras_vector(frame, r.u)))) {
        any = true;
        if (r.t_ns > last_t && r.t_ns > before_last_t + kStepNs) {
          found = r.t_ns;
          break;
        }
      }
    if (!any) ++unmatched;
    if (any && found < 0) ++too_close;
    if (found >= 0) ++spaced, before_last_t = last_t, last_t = found;
  }
  EXPECT_GE(spaced, 5u);
  EXPECT_LE(printed.size() / 3, 3u * 60u + 2u);
  // A tick missing from the recording can make a later copy of its values (the repeating
  // trajectory) the earliest match, after which the earlier ones cannot follow: only then may
  // samples fail the bound.
  if (missing == 0) {
    EXPECT_EQ(too_close, 0u) << "of " << printed.size() / 3 << " samples";
  }
  EXPECT_LE(unmatched, missing) << "of " << printed.size() / 3 << " samples";
  EXPECT_LT(unmatched, printed.size() / 3 / 10 + 1);
}

TEST(IgtlReceiveClient, TransformsMatchPalpdsTicksStoredLps) {
  check_storage("LPS");
}
TEST(IgtlReceiveClient, TransformsMatchPalpdsTicksStoredRas) {
  check_storage("RAS");
}

TEST(IgtlReceiveClient, ConfigFileKeysAndMistakes) {
  const fs::path dir = testing::shared_cli_dir() / "igtl-config";
  fs::create_directories(dir);
  const fs::path config = dir / "palpd.toml", log = dir / "palpd.log";
  {
    std::ofstream out(config);
    out << "igtl-port = 0\nigtl-rate = 30\nigtl-device = \"Finger,F,U\"\n";
  }
  ASSERT_GT(testing::start_palpd("--config '" + config.string() +
                                     "' --scene phantom:cube --device sim --port 0 --no-realtime "
                                     "--duration 1",
                                 log),
            0)
      << testing::read_text(log);
  ASSERT_TRUE(testing::wait_palpd_exit(log));
  EXPECT_TRUE(std::regex_search(testing::read_text(log),
                                std::regex("OpenIGTLink on 127\\.0\\.0\\.1:[0-9]+: Finger, F, U at "
                                           "30 Hz")))
      << testing::read_text(log);
  const auto refused = [&](const std::string& args, const std::string& says) {
    const std::string command = std::string(PALPD_PATH) + " --scene phantom:cube --device sim " +
                                args + " >'" + log.string() + "' 2>&1";
    EXPECT_EQ(WEXITSTATUS(std::system(command.c_str())), 2) << args;
    EXPECT_NE(testing::read_text(log).find(says), std::string::npos) << testing::read_text(log);
  };
  refused("--igtl-rate 30", "--igtl-rate needs --igtl-port");
  refused("--igtl-port 70000", "--igtl-port must be an integer in 0..65535");
  refused("--igtl-port 0 --igtl-device A,B", "--igtl-device needs TOOL or TOOL,FORCE,U");
  refused("--igtl-port 0 --igtl-device A,A,B", "must differ");
  refused("--igtl-port 0 --igtl-max-clients 65", "--igtl-max-clients must be an integer in 1..64");
}

}  // namespace
}  // namespace palp::interop
