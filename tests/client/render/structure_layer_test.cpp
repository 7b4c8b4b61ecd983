// The scene's structures in palpview (client/render/structure_layer.cpp through RenderScene),
// rendered off screen (CTest runs this under tests/tools/with_xvfb.sh where DISPLAY is unset; with
// no display the tests skip): a ball of tissue holding a ball "artery" and a slab of "vessel"; with
// the vessels preset the artery's red is where its mask projects and not beside it, the vessels'
// blue where theirs does, the artery brightens from diastole to systole with the stream's
// pulse_wave, and the legend names the structures; other presets, and volumes without labels,
// draw none of it.
#include "render/render_scene.hpp"

#include <gtest/gtest.h>
#include <vtkNew.h>
#include <vtkRenderWindow.h>

#include <cmath>
#include <cstdlib>
#include <memory>

#include "render/transfer_presets.hpp"

namespace palp::view {
namespace {

bool display_available() {
  const char* display = std::getenv("DISPLAY");
  return display && *display;
}

constexpr int kSize = 200;
constexpr std::int64_t kDim = 48;
constexpr double kSpacing = 2.0;
constexpr double kCentre = 47.0;  // mm: the tissue ball's centre on every axis
constexpr double kRadius = 30.0;  // the tissue ball
const Vec3d kArtery{40.0, 47.0, 52.0};
constexpr double kArteryRadius = 8.0;
constexpr double kSlabLo = 62.0, kSlabHi = 70.0;  // the vessel slab: x in [62, 70] mm

// Voxel (i, j, k) at (i, j, k) * 2 mm: the tissue ball's distance map; labels 2 in the artery,
// 1 in the slab (inside the tissue ball), 0 elsewhere.
std::shared_ptr<RenderVolume> labelled_volume(bool with_labels) {
  auto v = std::make_shared<RenderVolume>();
  v->dims = {kDim, kDim, kDim};
  v->spacing = {kSpacing, kSpacing, kSpacing};
  const auto n = static_cast<std::size_t>(kDim * kDim * kDim);
  v->d_surf.resize(n);
  if (with_labels) v->labels.resize(n);
  for (std::int64_t k = 0; k < kDim; ++k)
    for (std::int64_t j = 0; j < kDim; ++j)
      for (std::int64_t i = 0; i < kDim; ++i) {
        const Vec3d x{kSpacing * i, kSpacing * j, kSpacing * k};
        const auto at = static_cast<std::size_t>((k * kDim + j) * kDim + i);
        const double r = norm(x - Vec3d{kCentre, kCentre, kCentre});
        v->d_surf[at] = static_cast<float>(kRadius - r);
        if (!with_labels) continue;
        if (norm(x - kArtery) <= kArteryRadius)
          v->labels[at] = 2;
        else if (x.x >= kSlabLo && x.x <= kSlabHi && r < kRadius)
          v->labels[at] = 1;
      }
  return v;
}

LatestState state_with(std::shared_ptr<const RenderVolume> volume, double wave) {
  LatestState s;
  s.connection = 1;
  auto scene = std::make_shared<SceneDescription>();
  scene->tool = "finger:1";
  scene->device = "sim";
  scene->structures = {{1, "vessel", "vessel"}, {2, "artery", "artery"}};
  s.scene = scene;
  s.volume = std::move(volume);
  s.link.state = LinkState::Live;
  s.frame.valid = true;
  s.frame.pulse_wave = wave;
  s.frame.pulse_bpm = 72.0;
  return s;
}

struct Offscreen {
  vtkNew<vtkRenderWindow> window;
  std::unique_ptr<RenderScene> scene;
  explicit Offscreen(PresetId preset) {
    window->SetOffScreenRendering(1);
    window->SetSize(kSize, kSize);
    window->SetMultiSamples(0);
    SceneSettings settings;
    settings.preset = preset;
    settings.overlays = false;
    settings.tool_glyphs = false;
    settings.deformation = false;
    scene = std::make_unique<RenderScene>(window, settings);
  }
  ~Offscreen() { scene.reset(); }
  RgbImage draw(const LatestState& state) {
    scene->update_state(state, {});
    scene->render();
    return capture_rgb(window);
  }
  std::array<int, 3> at(const RgbImage& image, const Vec3d& point) const {
    const auto d = scene->to_display(point);
    const int x = static_cast<int>(d[0]), y = static_cast<int>(d[1]);
    const auto n = static_cast<std::size_t>(3 * (y * image.width + x));
    return {image.rgb[n], image.rgb[n + 1], image.rgb[n + 2]};
  }
};

bool red(const std::array<int, 3>& p) { return p[0] > 2 * p[1] + 20 && p[0] > 2 * p[2] + 20; }
bool blue(const std::array<int, 3>& p) { return p[2] > p[0] + 40 && p[2] > p[1] + 20; }

TEST(StructureLayer, TheVesselsPresetShowsTheArteryWhereItsMaskProjects) {
  if (!display_available()) GTEST_SKIP() << "no X display (run under with_xvfb.sh)";
  Offscreen view(PresetId::Vessels);
  const RgbImage image = view.draw(state_with(labelled_volume(true), 1.0));
  ASSERT_EQ(image.width, kSize);
  EXPECT_TRUE(view.scene->structures_visible());
  const auto centre = view.at(image, kArtery);
  EXPECT_TRUE(red(centre)) << centre[0] << "," << centre[1] << "," << centre[2];
  // Inside the tissue ball, beside the artery and the slab: no red, no blue.
  for (const Vec3d beside : {Vec3d{kArtery.x, kArtery.y, kArtery.z - 16.0},
                             Vec3d{kArtery.x - 14.0, kArtery.y, kArtery.z}}) {
    const auto p = view.at(image, beside);
    EXPECT_FALSE(red(p)) << p[0] << "," << p[1] << "," << p[2];
    EXPECT_FALSE(blue(p)) << p[0] << "," << p[1] << "," << p[2];
  }
  const auto slab = view.at(image, {0.5 * (kSlabLo + kSlabHi), kCentre, kCentre - 10.0});
  EXPECT_TRUE(blue(slab)) << slab[0] << "," << slab[1] << "," << slab[2];
  EXPECT_EQ(view.scene->legend_lines(),
            (std::vector<std::string>{"vessel", "artery  (pulse 72 bpm)"}));
}

TEST(StructureLayer, TheArteryBeatsWithThePulseWave) {
  if (!display_available()) GTEST_SKIP() << "no X display (run under with_xvfb.sh)";
  Offscreen view(PresetId::Vessels);
  const auto volume = labelled_volume(true);
  const RgbImage systole = view.draw(state_with(volume, 1.0));
  const RgbImage diastole = view.draw(state_with(volume, 0.0));
  const auto high = view.at(systole, kArtery), low = view.at(diastole, kArtery);
  EXPECT_GT(high[0], low[0] + 40) << high[0] << " vs " << low[0];
  // The vessels do not beat.
  const Vec3d slab{0.5 * (kSlabLo + kSlabHi), kCentre, kCentre - 10.0};
  EXPECT_EQ(view.at(systole, slab), view.at(diastole, slab));
}

// Another preset, or a volume without labels (an older palpd, a prep directory without
// structures): the structures are not drawn and the image is the one without them.
TEST(StructureLayer, NothingChangesWithoutTheVesselsPresetOrLabels) {
  if (!display_available()) GTEST_SKIP() << "no X display (run under with_xvfb.sh)";
  {
    Offscreen with(PresetId::Skin), without(PresetId::Skin);
    const RgbImage a = with.draw(state_with(labelled_volume(true), 1.0));
    const RgbImage b = without.draw(state_with(labelled_volume(false), 1.0));
    EXPECT_FALSE(with.scene->structures_visible());
    EXPECT_EQ(a.rgb, b.rgb);
  }
  Offscreen view(PresetId::Vessels);
  const RgbImage image = view.draw(state_with(labelled_volume(false), 1.0));
  EXPECT_FALSE(view.scene->structures_visible());
  EXPECT_TRUE(view.scene->legend_lines().empty());
  EXPECT_FALSE(red(view.at(image, kArtery)));
  // The vessels preset switched to and from at run time.
  const auto labelled = labelled_volume(true);
  view.scene->set_preset(PresetId::Skin);
  view.draw(state_with(labelled, 1.0));
  EXPECT_FALSE(view.scene->structures_visible());
  view.scene->set_preset(PresetId::Vessels);
  EXPECT_TRUE(view.scene->structures_visible());
  EXPECT_TRUE(red(view.at(view.draw(state_with(labelled, 1.0)), kArtery)));
}

}  // namespace
}  // namespace palp::view
