// palpview's command line end to end: help and usage errors; an unreachable server in screenshot
// mode (exit 1 after --timeout); a screenshot of palpd's sphere scene (the PNG has the asked size
// and is not uniform); and a controller run whose scripted poses drive palpd's `remote` device
// (palpd reports the pose back and finds the pad in contact); a prep directory's structures drawn
// by the vessels preset and not by the skin one; the landmarks shown from the start to an observer
// (--show-landmarks), never to the controller while a task runs. Rendering needs an X display
// (CTest runs this under xvfb-run -a where DISPLAY is unset); without one those tests skip.
#include <gtest/gtest.h>
#include <signal.h>
#include <unistd.h>
#include <vtkImageData.h>
#include <vtkNew.h>
#include <vtkPNGReader.h>
#include <vtkPointData.h>
#include <vtkUnsignedCharArray.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <numbers>
#include <regex>
#include <set>
#include <thread>

#include "anatomy/landmarks.hpp"
#include "io/ct_io.hpp"
#include "scene/trajectory.hpp"
#include "support/cli_test_util.hpp"
#include "support/outside_address.hpp"

namespace palp {
namespace {

namespace fs = std::filesystem;
using testing::read_text;
using testing::shared_cli_dir;

bool display_available() {
  const char* display = std::getenv("DISPLAY");
  return display && *display;
}

testing::CliOutcome run_palpview(const std::string& args) {
  return testing::run_command(std::string(PALPVIEW_PATH) + " " + args + " 2>&1 </dev/null");
}

// palpd in the background, stopped (SIGTERM) when this goes out of scope.
class Palpd {
 public:
  Palpd(const std::string& args, const fs::path& dir) : log_(dir / "palpd.log") {
    const fs::path pid_file = dir / "palpd.pid";
    const std::string command = "PALP_SCENE_CACHE='" + (shared_cli_dir() / "cache").string() +
                                "' " + PALPD_PATH + " " + args + " >'" + log_.string() +
                                "' 2>&1 </dev/null & echo $! >'" + pid_file.string() + "'";
    if (std::system(command.c_str()) != 0) return;
    pid_ = std::atoi(read_text(pid_file).c_str());
    const std::regex listening("listening on 127\\.0\\.0\\.1:([0-9]+)");
    for (int i = 0; i < 1200 && port_ == 0; ++i) {  // up to 2 min (first scene prep)
      std::smatch match;
      const std::string text = read_text(log_);
      if (std::regex_search(text, match, listening)) port_ = std::stoi(match[1]);
      if (text.find("error") != std::string::npos) break;
      if (port_ == 0) std::this_thread::sleep_for(std::chrono::milliseconds(100));
    }
  }
  ~Palpd() {
    if (pid_ > 0) ::kill(pid_, SIGTERM);
  }
  int port() const { return port_; }
  std::string log() const { return read_text(log_); }

 private:
  fs::path log_;
  int pid_ = 0;
  int port_ = 0;
};

fs::path test_dir() {
  const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
  const fs::path dir = shared_cli_dir() / info->name();
  fs::create_directories(dir);
  return dir;
}

struct Png {
  int width = 0, height = 0;
  std::size_t distinct_colours = 0;
};

Png read_png(const fs::path& path) {
  vtkNew<vtkPNGReader> reader;
  reader->SetFileName(path.string().c_str());
  reader->Update();
  vtkImageData* image = reader->GetOutput();
  int dims[3] = {0, 0, 0};
  image->GetDimensions(dims);
  Png out{dims[0], dims[1], 0};
  auto* pixels = vtkUnsignedCharArray::SafeDownCast(image->GetPointData()->GetScalars());
  if (!pixels) return out;
  const int nc = pixels->GetNumberOfComponents();
  std::set<std::uint32_t> colours;
  for (vtkIdType i = 0; i < pixels->GetNumberOfTuples(); ++i) {
    std::uint32_t c = 0;
    for (int k = 0; k < std::min(nc, 3); ++k) c = (c << 8) | pixels->GetValue(i * nc + k);
    colours.insert(c);
  }
  out.distinct_colours = colours.size();
  return out;
}

// The RGB bytes of a PNG, row by row.
std::vector<std::uint8_t> read_rgb(const fs::path& path) {
  vtkNew<vtkPNGReader> reader;
  reader->SetFileName(path.string().c_str());
  reader->Update();
  auto* pixels =
      vtkUnsignedCharArray::SafeDownCast(reader->GetOutput()->GetPointData()->GetScalars());
  std::vector<std::uint8_t> out;
  if (!pixels) return out;
  const int nc = pixels->GetNumberOfComponents();
  for (vtkIdType i = 0; i < pixels->GetNumberOfTuples(); ++i)
    for (int k = 0; k < std::min(nc, 3); ++k) out.push_back(pixels->GetValue(i * nc + k));
  return out;
}

double mean_abs_difference(const std::vector<std::uint8_t>& a, const std::vector<std::uint8_t>& b) {
  if (a.size() != b.size() || a.empty()) return 1e9;
  double sum = 0;
  for (std::size_t i = 0; i < a.size(); ++i) sum += std::abs(int{a[i]} - int{b[i]});
  return sum / static_cast<double>(a.size());
}

TEST(Palpview, HelpAndUsageErrors) {
  auto r = run_palpview("--help");
  EXPECT_EQ(r.exit_code, 0);
  EXPECT_NE(r.output.find("--connect HOST:PORT"), std::string::npos);
  EXPECT_NE(r.output.find("--screenshot FILE"), std::string::npos);
  r = run_palpview("");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.output.find("--connect HOST:PORT is required"), std::string::npos) << r.output;
  r = run_palpview("--connect 127.0.0.1:7400 --bogus");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.output.find("unknown option '--bogus'"), std::string::npos) << r.output;
  EXPECT_EQ(run_palpview("--connect nocolon").exit_code, 2);
  EXPECT_EQ(run_palpview("--connect 127.0.0.1:7400 --preset lung").exit_code, 2);
  EXPECT_EQ(run_palpview("--connect 127.0.0.1:7400 --frames 3").exit_code, 2);
  EXPECT_EQ(run_palpview("--connect 127.0.0.1:7400 --width 10").exit_code, 2);
  EXPECT_EQ(run_palpview("--connect 127.0.0.1:7400 --camera 1,2").exit_code, 2);
  EXPECT_EQ(run_palpview("--connect 127.0.0.1:7400 --rate").exit_code, 2);
  EXPECT_EQ(run_palpview("--connect 127.0.0.1:7400 --script x.csv").exit_code, 2);
  EXPECT_EQ(run_palpview("--connect 127.0.0.1:7400 --view front").exit_code, 2);
}

// The same torso stored LPS, RAS and PIR: the default view is the patient's anterior in all
// three (the same picture), and it is not the posterior view.
TEST(Palpview, DefaultViewIsThePatientsAnteriorHoweverStored) {
  if (!display_available()) GTEST_SKIP() << "no X display (run under xvfb-run -a)";
  const fs::path dir = test_dir();
  std::map<std::string, std::vector<std::uint8_t>> shots;
  for (const std::string code : {"LPS", "RAS", "PIR", "LPS posterior"}) {
    const std::string stored = code.substr(0, 3);
    const fs::path ct = dir / ("torso_" + stored + ".nii.gz");
    if (!fs::exists(ct)) {
      const auto made = testing::run_palp_cli(
          "phantom torso --dims 96x64x24 --spacing 5x5x8 "
          "--orientation " +
              stored + " --out " + ct.string(),
          shared_cli_dir() / "cache");
      ASSERT_EQ(made.exit_code, 0) << made.output;
    }
    // A directory of its own per palpd: its log (where the port is read) starts empty, never
    // holding the previous run's port.
    const fs::path run_dir = dir / ("palpd_" + std::to_string(shots.size()));
    fs::create_directories(run_dir);
    Palpd palpd("--scene " + ct.string() + " --device sim --port 0 --no-realtime --duration 300",
                run_dir);
    ASSERT_GT(palpd.port(), 0) << palpd.log();
    const fs::path png = dir / ("view_" + stored + (code.size() > 3 ? "_posterior" : "") + ".png");
    const auto r = run_palpview("--connect 127.0.0.1:" + std::to_string(palpd.port()) +
                                " --screenshot " + png.string() +
                                " --frames 2 --width 240 --height 160 --timeout 120 --no-tool"
                                " --no-deformation --no-overlays --follow 0" +
                                (code.size() > 3 ? " --view posterior" : ""));
    ASSERT_EQ(r.exit_code, 0) << r.output;
    shots[code] = read_rgb(png);
  }
  const double ras = mean_abs_difference(shots["LPS"], shots["RAS"]);
  const double pir = mean_abs_difference(shots["LPS"], shots["PIR"]);
  const double back = mean_abs_difference(shots["LPS"], shots["LPS posterior"]);
  std::printf(
      "mean |difference| from the LPS default view (grey levels): RAS %.4f, PIR %.4f, "
      "LPS posterior %.4f\n",
      ras, pir, back);
  EXPECT_LT(ras, 0.5) << "RAS differs from LPS";
  EXPECT_LT(pir, 0.5) << "PIR differs from LPS";
  EXPECT_GT(back, 2.0) << "the posterior view looks like the anterior one: the test cannot fail";
}

TEST(Palpview, UnreachableServerFailsAfterTheTimeout) {
  if (!display_available()) GTEST_SKIP() << "no X display (run under xvfb-run -a)";
  const fs::path dir = test_dir();
  // Port 1 on the loopback: nothing listens there.
  const auto started = std::chrono::steady_clock::now();
  const auto r = run_palpview("--connect 127.0.0.1:1 --screenshot " + (dir / "x.png").string() +
                              " --timeout 1.5 --width 160 --height 120");
  const double took =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
  EXPECT_EQ(r.exit_code, 1) << r.output;
  EXPECT_NE(r.output.find("no scene from 127.0.0.1:1 within 1.5 s"), std::string::npos) << r.output;
  EXPECT_GE(took, 1.5);
  EXPECT_FALSE(fs::exists(dir / "x.png"));
}

// --token is "sent only over TLS or loopback" (its help): to another machine without
// --tls-ca/--tls-pin palpview refuses before it connects (or opens a window), naming them.
TEST(Palpview, ATokenIsNeverSentInClearTextOffLoopback) {
  const fs::path dir = test_dir();
  const auto started = std::chrono::steady_clock::now();
  // 192.0.2.1 (TEST-NET-1) answers nothing: a palpview that tried would wait for its timeout.
  auto r = run_palpview("--connect 192.0.2.1:7400 --controller --token s3cret --screenshot " +
                        (dir / "x.png").string() + " --timeout 20 --width 160 --height 120");
  const double took =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("clear text"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("--tls-ca"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("--tls-pin"), std::string::npos) << r.output;
  EXPECT_LT(took, 10.0);
  if (const std::string outside = testing::outside_address(); !outside.empty()) {
    const testing::SilentListener listener;
    r = run_palpview("--connect " + outside + ":" + std::to_string(listener.port()) +
                     " --token s3cret --screenshot " + (dir / "x.png").string() +
                     " --timeout 3 --width 160 --height 120");
    EXPECT_EQ(r.exit_code, 2) << r.output;
    EXPECT_NE(r.output.find("--tls-ca"), std::string::npos) << r.output;
    EXPECT_FALSE(listener.connected()) << "palpview connected: " << r.output;
  }
  r = run_palpview("--connect 192.0.2.1:7400 --tls-cert s.crt --tls-key s.key");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("--tls-ca FILE or --tls-pin"), std::string::npos) << r.output;
  EXPECT_FALSE(fs::exists(dir / "x.png"));
}

TEST(Palpview, ScreenshotOfTheLiveStream) {
  if (!display_available()) GTEST_SKIP() << "no X display (run under xvfb-run -a)";
  const fs::path dir = test_dir();
  Palpd palpd("--scene phantom:sphere --device sim --port 0 --no-realtime --duration 300", dir);
  ASSERT_GT(palpd.port(), 0) << palpd.log();
  const fs::path png = dir / "out.png", stats = dir / "stats.json";
  const auto r = run_palpview(
      "--connect 127.0.0.1:" + std::to_string(palpd.port()) + " --screenshot " + png.string() +
      " --frames 5 --width 320 --height 240 --timeout 120 --stats-json " + stats.string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("receive"), std::string::npos) << r.output;
  ASSERT_TRUE(fs::exists(png));
  const Png image = read_png(png);
  EXPECT_EQ(image.width, 320);
  EXPECT_EQ(image.height, 240);
  EXPECT_GE(image.distinct_colours, 16u);  // volume, shading, HUD text: far from uniform
  const auto j = nlohmann::json::parse(read_text(stats));
  EXPECT_EQ(j.at("live_frames").get<int>(), 5);
  EXPECT_EQ(j.at("render_ms").at("n").get<int>(), 5);
  EXPECT_EQ(j.at("width").get<int>(), 320);
  EXPECT_TRUE(j.at("last_frame_valid").get<bool>());
}

// Pixels of an RGB image that are clearly red (the artery) or clearly blue (the vessels).
std::size_t count_pixels(const std::vector<std::uint8_t>& rgb, bool red) {
  std::size_t n = 0;
  for (std::size_t i = 0; i + 2 < rgb.size(); i += 3) {
    const int r = rgb[i], g = rgb[i + 1], b = rgb[i + 2];
    n += red ? (r > 2 * g + 20 && r > 2 * b + 20) : (b > r + 40 && b > g + 20);
  }
  return n;
}

// The structures end to end: a prep directory of the sphere phantom with a tube "artery" inside
// a "vessel" mask written here -> palpd (SceneInfo.structures, VolumeChunk.labels) -> palpview's
// vessels preset draws red and blue; its skin preset, on the same stream, neither.
TEST(Palpview, TheVesselsPresetShowsThePrepDirectorysStructures) {
  if (!display_available()) GTEST_SKIP() << "no X display (run under xvfb-run -a)";
  const fs::path dir = test_dir(), prep = dir / "prep";
  fs::remove_all(prep);
  const auto prepped = testing::run_palp_cli("prep phantom:sphere --out " + prep.string(), dir);
  ASSERT_EQ(prepped.exit_code, 0) << prepped.output;
  // The sphere: radius 30 mm about the centre of its 100^3 grid of 1 mm. A tube of radius 5 mm
  // along k, 12 mm beside the centre, is the artery; the vessels are that tube and another.
  const Mask body = read_nifti_mask((prep / "body.nii.gz").string());
  Mask artery(body.grid), vessel(body.grid);
  for (std::int64_t k = 25; k <= 75; ++k)
    for (std::int64_t j = 0; j < 100; ++j)
      for (std::int64_t i = 0; i < 100; ++i) {
        const bool tube = std::pow(i - 37.5, 2) + std::pow(j - 49.5, 2) <= 25;
        artery.at(i, j, k) = tube;
        vessel.at(i, j, k) = tube || std::pow(i - 62.0, 2) + std::pow(j - 55.0, 2) <= 16;
      }
  write_nifti((prep / "artery.nii.gz").string(), artery);
  write_nifti((prep / "vessel.nii.gz").string(), vessel);
  Palpd palpd("--scene " + prep.string() + " --device sim --port 0 --no-realtime --duration 300",
              dir);
  ASSERT_GT(palpd.port(), 0) << palpd.log();
  EXPECT_NE(palpd.log().find("structures for the clients: vessel, artery"), std::string::npos);
  std::map<std::string, std::vector<std::uint8_t>> shots;
  for (const std::string preset : {"vessels", "skin"}) {
    const fs::path png = dir / (preset + ".png");
    const auto r = run_palpview("--connect 127.0.0.1:" + std::to_string(palpd.port()) +
                                " --preset " + preset + " --screenshot " + png.string() +
                                " --frames 3 --width 320 --height 240 --timeout 120 --follow 0"
                                " --no-overlays --no-tool");
    ASSERT_EQ(r.exit_code, 0) << r.output;
    shots[preset] = read_rgb(png);
  }
  EXPECT_GT(count_pixels(shots["vessels"], true), 200u);   // the artery: ~10 x 50 mm
  EXPECT_GT(count_pixels(shots["vessels"], false), 100u);  // the other vessel: ~8 x 50 mm
  EXPECT_EQ(count_pixels(shots["skin"], true), 0u);
  EXPECT_EQ(count_pixels(shots["skin"], false), 0u);
}

// A stream lost before the screenshot's frames arrived: exit 1 at once, no picture of the stale
// scene ("CONNECTION LOST" in a PNG that claims success).
TEST(Palpview, StreamLostBeforeTheScreenshotFails) {
  if (!display_available()) GTEST_SKIP() << "no X display (run under xvfb-run -a)";
  const fs::path dir = test_dir();
  Palpd palpd("--scene phantom:sphere --device sim --port 0 --no-realtime --duration 4", dir);
  ASSERT_GT(palpd.port(), 0) << palpd.log();
  const fs::path png = dir / "lost.png";
  const auto started = std::chrono::steady_clock::now();
  const auto r =
      run_palpview("--connect 127.0.0.1:" + std::to_string(palpd.port()) + " --screenshot " +
                   png.string() + " --frames 100000 --width 160 --height 120 --timeout 120");
  const double took =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
  EXPECT_EQ(r.exit_code, 1) << r.output;
  EXPECT_NE(r.output.find("was lost after"), std::string::npos) << r.output;
  EXPECT_FALSE(fs::exists(png));
  EXPECT_LT(took, 60.0);  // not the 120 s timeout
}

// Pixels of the landmarks' colour (yellow spheres and labels): red and green high, blue low.
struct Yellow {
  std::size_t n = 0;
  double mean_column = 0;
};

Yellow yellow_pixels(const std::vector<std::uint8_t>& rgb, int width) {
  Yellow out;
  double columns = 0;
  for (std::size_t i = 0; i + 2 < rgb.size(); i += 3) {
    const int r = rgb[i], g = rgb[i + 1], b = rgb[i + 2];
    if (r < 150 || g < 120 || r - b < 90 || g - b < 70) continue;
    ++out.n;
    columns += static_cast<double>((i / 3) % static_cast<std::size_t>(width));
  }
  if (out.n) out.mean_column = columns / static_cast<double>(out.n);
  return out;
}

// The sphere phantom (radius 30 mm about LPS (0, 0, 0)) as a chest wall on the patient's right
// (LPS -x): ribs 9 and 10 12 mm above and below the equator, the 9/10 space's skin point between.
fs::path write_right_side_landmarks(const fs::path& dir) {
  anatomy::Landmarks l;
  l.scene = "phantom:sphere";
  anatomy::IntercostalSpace space;
  space.upper_rib = 9;
  space.skin_point = Vec3d{-30.0, -10.0, 0.0};
  space.normal = Vec3d{-1.0, 0.0, 0.0};
  space.confidence = 1.0;
  l.intercostal_spaces.push_back(space);
  for (const int number : {9, 10}) {
    anatomy::Rib rib;
    rib.number = number;
    rib.confidence = 1.0;
    const double z = number == 9 ? 12.0 : -12.0;
    for (double y = -25.0; y <= 5.0; y += 5.0)
      rib.points.push_back({-std::sqrt(900.0 - z * z - y * y), y, z});
    l.ribs.push_back(rib);
  }
  const fs::path path = dir / "landmarks.json";
  anatomy::write_landmarks(path.string(), l);
  return path;
}

// --show-landmarks end to end: palpd --landmarks sends the set, palpview draws it from the start
// for an observer (yellow, on the patient's right: the image's left from the anterior view), not
// without the option, and not for the trainee's controller while a task runs.
TEST(Palpview, ShowLandmarksDrawsThemForTheObserverOnly) {
  if (!display_available()) GTEST_SKIP() << "no X display (run under xvfb-run -a)";
  const fs::path dir = test_dir();
  Palpd palpd(
      "--scene phantom:sphere --device remote --port 0 --no-realtime --duration 300 "
      "--landmarks " +
          write_right_side_landmarks(dir).string() + " --task ptcd --record-dir " + dir.string(),
      dir);
  ASSERT_GT(palpd.port(), 0) << palpd.log();
  const int width = 400, height = 300;
  const auto shot = [&](const std::string& name, const std::string& options) {
    const fs::path png = dir / (name + ".png");
    const auto r =
        run_palpview("--connect 127.0.0.1:" + std::to_string(palpd.port()) + " " + options +
                     " --preset bone --screenshot " + png.string() + " --frames 5 --width " +
                     std::to_string(width) + " --height " + std::to_string(height) +
                     " --timeout 120 --follow 0 --no-overlays --no-tool");
    EXPECT_EQ(r.exit_code, 0) << r.output;
    return yellow_pixels(read_rgb(png), width);
  };
  const Yellow shown = shot("observer-shown", "--show-landmarks");
  const Yellow plain = shot("observer-plain", "");
  const Yellow trainee = shot("controller-shown", "--controller --show-landmarks");
  // 15 points of 2.5 mm radius and three labels on a ~120 mm field 300 px high
  EXPECT_GT(shown.n, 150u);
  EXPECT_LT(shown.mean_column, 0.5 * width);  // the patient's right
  EXPECT_LT(plain.n, 5u);
  EXPECT_LT(trainee.n, 5u);
}

TEST(Palpview, ControllerScriptDrivesTheRemoteDevice) {
  if (!display_available()) GTEST_SKIP() << "no X display (run under xvfb-run -a)";
  const fs::path dir = test_dir();
  Palpd palpd("--scene phantom:sphere --device remote --port 0 --no-realtime --duration 300", dir);
  ASSERT_GT(palpd.port(), 0) << palpd.log();
  // The sphere phantom: radius 30 mm about the centre of its 100^3 grid of 1 mm (49.5 mm). The
  // finger comes from the front (-y) along +y and ends with its pad 4 mm into the ball.
  Trajectory script(2);
  for (auto& row : script) row.pose.orientation = axis_angle({1, 0, 0}, 0.5 * std::numbers::pi);
  script[0].t = 0.0;
  script[0].pose.position = {49.5, 49.5 - 30.0 - 20.0 - 8.0, 49.5};
  script[1].t = 0.1;
  script[1].pose.position = {49.5, 49.5 - 30.0 + 4.0 - 8.0, 49.5};
  const fs::path csv = dir / "script.csv", png = dir / "press.png", stats = dir / "stats.json";
  write_trajectory_csv(csv.string(), script);
  const auto r =
      run_palpview("--connect 127.0.0.1:" + std::to_string(palpd.port()) +
                   " --controller --script " + csv.string() + " --screenshot " + png.string() +
                   " --frames 40 --width 240 --height 180 --timeout 120 "
                   "--stats-json " +
                   stats.string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const auto j = nlohmann::json::parse(read_text(stats));
  ASSERT_TRUE(j.at("last_frame_valid").get<bool>());
  // palpd ticked with the scripted pose and found the pad in contact.
  const auto pose = j.at("last_pose").get<std::vector<double>>();
  ASSERT_EQ(pose.size(), 7u);
  EXPECT_NEAR(pose[0], script[1].pose.position.x, 1e-6);
  EXPECT_NEAR(pose[1], script[1].pose.position.y, 1e-6);
  EXPECT_NEAR(pose[2], script[1].pose.position.z, 1e-6);
  EXPECT_NEAR(pose[3], script[1].pose.orientation.w, 1e-6);
  EXPECT_NEAR(pose[4], script[1].pose.orientation.x, 1e-6);
  EXPECT_GT(j.at("max_contacts").get<int>(), 0);
  EXPECT_GT(j.at("deformation_active_frames").get<int>(), 0);
}

}  // namespace
}  // namespace palp
