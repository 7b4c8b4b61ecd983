// palpview's scene (client/render/render_scene.hpp) and transfer presets: HUD and banner text
// without a display; with one (CTest runs this under xvfb-run -a where DISPLAY is unset) a tiny
// ball is ray cast in an off-screen window and the pixels are checked: the ball is visible,
// pressing the finger into it (SkinDeformer) changes the image inside the projected ROI only, and
// the three presets give different images. Without a display the rendering tests skip.
#include "render/render_scene.hpp"

#include <gtest/gtest.h>
#include <vtkNew.h>
#include <vtkRenderWindow.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <numbers>

#include "base/errors.hpp"
#include "model/tool.hpp"
#include "render/skin_surface.hpp"
#include "render/transfer_presets.hpp"
#include "render/workspace_box.hpp"

namespace palp::view {
namespace {

bool display_available() {
  const char* display = std::getenv("DISPLAY");
  return display && *display;
}

// ------------------------------------------------------------------ pure parts

TEST(TransferPresets, ComposesThePseudoDensity) {
  EXPECT_EQ(render_scalar(-5.0f, -50.0f, true), -1000.0f);  // air
  EXPECT_EQ(render_scalar(0.0f, -50.0f, true), -500.0f);    // on the skin: half the step
  EXPECT_EQ(render_scalar(15.0f, -50.0f, true), 30.0f);     // soft tissue, half the rise
  EXPECT_EQ(render_scalar(40.0f, -50.0f, true), 60.0f);     // deep: the full rise
  EXPECT_EQ(render_scalar(40.0f, 0.0f, true), 560.0f);      // on the bone surface
  EXPECT_EQ(render_scalar(40.0f, 3.0f, true), 1060.0f);     // inside bone
  EXPECT_EQ(render_scalar(40.0f, 3.0f, false), 60.0f);      // no bone map
  const std::vector<float> surf{-5.0f, 0.0f, 40.0f}, bone{-50.0f, -50.0f, 3.0f};
  EXPECT_EQ(compose_render_scalar(surf, bone), (std::vector<float>{-1000.0f, -500.0f, 1060.0f}));
  EXPECT_EQ(compose_render_scalar(surf, {}), (std::vector<float>{-1000.0f, -500.0f, 60.0f}));
  EXPECT_THROW(compose_render_scalar(surf, std::vector<float>(2)), UsageError);
}

TEST(TransferPresets, PresetsAndWindowing) {
  EXPECT_EQ(parse_preset("skin"), PresetId::Skin);
  EXPECT_EQ(parse_preset("bone"), PresetId::Bone);
  EXPECT_EQ(parse_preset("soft"), PresetId::Soft);
  EXPECT_THROW(parse_preset("lung"), UsageError);
  // The skin preset's window centres on the skin's iso-value: its opacity rises across -500.
  const Preset skin = make_preset(PresetId::Skin);
  EXPECT_EQ(skin.window.level, -500.0);
  EXPECT_LT(point_value(skin.points[1], skin.window), -500.0);
  EXPECT_GT(point_value(skin.points[2], skin.window), -500.0);
  EXPECT_EQ(skin.points[1].opacity, 0.0);
  EXPECT_GT(skin.points[2].opacity, 0.5);
  // The bone preset is opaque at bone (1060) and nearly transparent in soft tissue (60).
  const Preset bone = make_preset(PresetId::Bone);
  EXPECT_GT(point_value(bone.points.back(), bone.window), 800.0);
  EXPECT_LE(bone.points[2].opacity, 0.05);
  for (PresetId id : {PresetId::Skin, PresetId::Bone, PresetId::Soft}) {
    const Preset p = make_preset(id);
    for (std::size_t n = 1; n < p.points.size(); ++n) EXPECT_LT(p.points[n - 1].t, p.points[n].t);
  }
  // Windowing: level shifts every point, width scales about the level, never below the minimum.
  const Window w = adjust_window({100.0, 200.0}, 50.0, 2.0);
  EXPECT_EQ(w.level, 150.0);
  EXPECT_EQ(w.width, 400.0);
  EXPECT_EQ(point_value({0.0, {}, 0.0}, w), -50.0);
  EXPECT_EQ(point_value({1.0, {}, 0.0}, w), 350.0);
  EXPECT_EQ(adjust_window({0.0, 2.0}, 0.0, 0.01).width, kMinWindowWidth);
}

LatestState live_state() {
  LatestState s;
  s.connection = 1;
  auto scene = std::make_shared<SceneDescription>();
  scene->tool = "finger:37";
  scene->tool_points = parse_tool("finger:37").points;
  scene->device = "sim";
  s.scene = scene;
  s.link.state = LinkState::Live;
  s.link.connections = 1;
  s.link.frames_per_s = 120;
  s.link.delivered = 1.0;
  s.link.latency_ms = 0.8;
  s.link.server_tick_rate_hz = 1000;
  s.frame.valid = true;
  s.frame.device_state = DeviceState::Present;
  return s;
}

TEST(Hud, BannerShowsStallsDropsAndDeviceProblems) {
  LatestState s = live_state();
  EXPECT_EQ(banner_text(s), "");
  s.link.state = LinkState::Stalled;
  s.link.since_last_frame_s = 1.25;
  EXPECT_EQ(banner_text(s), "STREAM STALLED: no frame for 1.2 s");
  s.link.state = LinkState::Reconnecting;
  s.link.message = "connection refused";
  EXPECT_EQ(banner_text(s), "CONNECTION LOST: reconnecting (connection refused)");
  s.link.state = LinkState::Refused;
  s.link.message = "wrong token";
  EXPECT_EQ(banner_text(s), "REFUSED by palpd (wrong token)");
  s = live_state();
  s.frame.device_state = DeviceState::Absent;
  s.link.device_message = "unplugged";
  EXPECT_EQ(banner_text(s), "DEVICE ABSENT (unplugged)");
  s.frame.device_state = DeviceState::Fault;
  s.frame.fault = 4;
  s.link.server_paused = true;
  EXPECT_EQ(banner_text(s), "DEVICE FAULT 4 (unplugged)\nPAUSED");
  s = live_state();
  s.link.state = LinkState::Loading;
  s.link.volume_progress = 0.5;
  EXPECT_EQ(banner_text(s), "LOADING scene 50%");
}

TEST(Hud, ControllerSeesItsKeysRecordingAndTheLastAnswer) {
  LatestState s = live_state();
  HudInputs in;
  in.controller = true;
  EXPECT_NE(hud_text(s, in).find("O record"), std::string::npos);
  EXPECT_EQ(hud_text(s, in).find("last command"), std::string::npos);  // none yet
  s.link.last_request_id = 3;
  s.link.last_result_ok = false;
  s.link.last_result_message = "trial-1 already exists";
  EXPECT_NE(hud_text(s, in).find("last command refused: trial-1 already exists"),
            std::string::npos);
  in.controller = false;
  EXPECT_EQ(hud_text(s, in).find("O record"), std::string::npos);
  s.link.server_recording = true;
  EXPECT_NE(banner_text(s).find("RECORDING"), std::string::npos);
}

// The pulse's line: from a palpd that reports the rate, with what is felt of it when non-zero;
// none from one that does not; the controller's keys name , . B.
TEST(Hud, ThePulsesLine) {
  LatestState s = live_state();
  EXPECT_EQ(hud_text(s, {}).find("pulse"), std::string::npos);
  s.frame.pulse_bpm = 72.0;
  EXPECT_NE(hud_text(s, {}).find("pulse 72 bpm\n"), std::string::npos) << hud_text(s, {});
  s.frame.pulse_force = 0.25;
  s.frame.organ_force = 1.5;
  EXPECT_NE(hud_text(s, {}).find("pulse 72 bpm   felt 0.25 N   organ 1.50 N"), std::string::npos)
      << hud_text(s, {});
  s.frame.pulse_force = 0.004;  // would read 0.00: not shown
  EXPECT_EQ(hud_text(s, {}).find("felt"), std::string::npos);
  s.frame.pulse_bpm = 0.0;
  EXPECT_NE(hud_text(s, {}).find("pulse off"), std::string::npos);
  HudInputs in;
  in.controller = true;
  EXPECT_NE(hud_text(s, in).find(",/. pulse -/+  B pulse on/off"), std::string::npos);
}

TEST(Hud, TextShowsRatesAndForceRendering) {
  LatestState s = live_state();
  s.frame.n_contact = 7;
  s.frame.contact_points = 37;
  HudInputs in;
  in.view_fps = 59.94;
  const std::string text = hud_text(s, in);
  EXPECT_NE(text.find("observer  link live"), std::string::npos) << text;
  EXPECT_NE(text.find("view 59.9 fps   stream 120 frames/s"), std::string::npos) << text;
  EXPECT_NE(text.find("latency 0.8 ms   delivered 100.0%"), std::string::npos) << text;
  EXPECT_NE(text.find("tick rate 1000 Hz"), std::string::npos) << text;
  EXPECT_NE(text.find("contacts 7/37"), std::string::npos) << text;
  s.link.latency_ms = -1;
  s.link.connections = 3;
  const std::string later = hud_text(s, in);
  EXPECT_NE(later.find("latency n/a"), std::string::npos) << later;
  EXPECT_NE(later.find("(reconnected 2x)"), std::string::npos) << later;

  s.frame.force = {3, 0, 4};
  EXPECT_EQ(force_text(s), "force 5.00 N  (3.00, 0.00, 4.00)");
  auto scene = std::make_shared<SceneDescription>(*s.scene);
  scene->device_renders_force = false;
  s.scene = scene;
  EXPECT_NE(force_text(s).find("force not rendered by the device"), std::string::npos);
}

// ------------------------------------------------------------------ rendering

constexpr int kSize = 160;
constexpr std::int64_t kDim = 48;
constexpr double kSpacing = 2.0;
constexpr double kCentre = 47.0;  // mm, the ball's centre on every axis
constexpr double kRadius = 30.0;

std::shared_ptr<const RenderVolume> ball_volume() {
  auto v = std::make_shared<RenderVolume>();
  v->dims = {kDim, kDim, kDim};
  v->spacing = {kSpacing, kSpacing, kSpacing};
  v->d_surf.resize(kDim * kDim * kDim);
  v->d_bone.resize(kDim * kDim * kDim);
  for (std::int64_t k = 0; k < kDim; ++k)
    for (std::int64_t j = 0; j < kDim; ++j)
      for (std::int64_t i = 0; i < kDim; ++i) {
        const double r =
            std::sqrt(std::pow(kSpacing * i - kCentre, 2) + std::pow(kSpacing * j - kCentre, 2) +
                      std::pow(kSpacing * k - kCentre, 2));
        const auto n = static_cast<std::size_t>((k * kDim + j) * kDim + i);
        v->d_surf[n] = static_cast<float>(kRadius - r);
        v->d_bone[n] = static_cast<float>(10.0 - r);
      }
  return v;
}

// The finger pressing `depth` mm into the ball's front (-y side, facing the camera), along +y;
// contacts and proxies as the force model would report them (proxy = the nearest skin point).
LatestState pressed_state(std::shared_ptr<const RenderVolume> volume, double depth) {
  LatestState s = live_state();
  s.volume = std::move(volume);
  s.frame.pose.orientation = axis_angle({1, 0, 0}, 0.5 * std::numbers::pi);
  s.frame.pose.position = {kCentre, kCentre - kRadius + depth + kFingerPadZ, kCentre};
  for (const Vec3d& t : s.scene->tool_points) {
    ContactState c;
    c.x = s.frame.pose.position + rotate(s.frame.pose.orientation, t);
    const Vec3d radial = c.x - Vec3d{kCentre, kCentre, kCentre};
    const double r = norm(radial);
    c.in_contact = r < kRadius;
    c.s = c.p = c.in_contact ? Vec3d{kCentre, kCentre, kCentre} + radial * (kRadius / r) : c.x;
    s.frame.n_contact += c.in_contact;
    s.frame.contacts.push_back(c);
  }
  s.frame.contact_points = static_cast<std::uint32_t>(s.frame.contacts.size());
  return s;
}

struct Offscreen {
  vtkNew<vtkRenderWindow> window;
  std::unique_ptr<RenderScene> scene;
  explicit Offscreen(SceneSettings settings) {
    window->SetOffScreenRendering(1);
    window->SetSize(kSize, kSize);
    window->SetMultiSamples(0);
    scene = std::make_unique<RenderScene>(window, settings);
  }
  ~Offscreen() { scene.reset(); }
  RgbImage draw(const LatestState& state) {
    scene->update_state(state, {});
    last_deform = scene->update_deformation();
    scene->render();
    return capture_rgb(window);
  }
  DeformResult last_deform;
};

std::array<int, 3> pixel(const RgbImage& image, int x, int y) {
  const auto n = static_cast<std::size_t>(3 * (y * image.width + x));
  return {image.rgb[n], image.rgb[n + 1], image.rgb[n + 2]};
}

int pixel_difference(const RgbImage& a, const RgbImage& b, int x, int y) {
  const auto pa = pixel(a, x, y), pb = pixel(b, x, y);
  return std::max({std::abs(pa[0] - pb[0]), std::abs(pa[1] - pb[1]), std::abs(pa[2] - pb[2])});
}

std::size_t differing_pixels(const RgbImage& a, const RgbImage& b) {
  std::size_t n = 0;
  for (int y = 0; y < a.height; ++y)
    for (int x = 0; x < a.width; ++x) n += pixel_difference(a, b, x, y) > 8;
  return n;
}

SceneSettings quiet_settings() {
  SceneSettings settings;
  settings.overlays = false;
  settings.tool_glyphs = false;
  settings.camera_elevation_deg = 20.0;  // a little from above: the pressed front is in view
  return settings;
}

TEST(RenderScene, TheBallIsVisible) {
  if (!display_available()) GTEST_SKIP() << "no X display (run under xvfb-run -a)";
  Offscreen view(quiet_settings());
  LatestState state = live_state();
  state.volume = ball_volume();
  const RgbImage image = view.draw(state);
  ASSERT_EQ(image.width, kSize);
  ASSERT_EQ(image.height, kSize);
  ASSERT_TRUE(view.scene->has_volume());
  const auto centre = view.scene->to_display({kCentre, kCentre, kCentre});
  const auto background = pixel(image, 1, 1);
  // The ball's centre projects onto skin-coloured pixels; the corner is the background.
  const auto at_centre = pixel(image, static_cast<int>(centre[0]), static_cast<int>(centre[1]));
  EXPECT_GT(at_centre[0], background[0] + 60);
  EXPECT_GT(at_centre[0], at_centre[2]);  // skin: red over blue
  // Everything outside the ball's projected disc is background.
  const auto edge = view.scene->to_display({kCentre + kRadius, kCentre, kCentre});
  const double disc = std::abs(edge[0] - centre[0]);
  ASSERT_GT(disc, 10.0);
  std::size_t inside_lit = 0, inside = 0;
  for (int y = 0; y < kSize; ++y)
    for (int x = 0; x < kSize; ++x) {
      const double r = std::hypot(x + 0.5 - centre[0], y + 0.5 - centre[1]);
      if (r > 1.15 * disc + 2) {
        EXPECT_EQ(pixel(image, x, y), background) << x << "," << y;
      }
      if (r < 0.9 * disc) {
        ++inside;
        inside_lit += pixel(image, x, y) != background;
      }
    }
  EXPECT_EQ(inside_lit, inside);
}

TEST(WorkspaceBox, CornersFollowTheRegistration) {
  SceneDescription::Placement p;
  p.rotation = {0, 0, -1, 0, -1, 0, -1, 0, 0};  // IAR in an LPS scene
  p.scale = 2.0;
  p.workspace_half_mm = {10, 20, 30};
  const auto corners = workspace_corners(p, {100, 100, 100});
  // Corner 0 is (-10, -20, -30) on the device: R (..) = (30, 20, 10), times 2.
  EXPECT_EQ(corners[0], (Vec3d{160, 140, 120}));
  EXPECT_EQ(corners[7], (Vec3d{40, 60, 80}));
}

// A device placed on the patient shows its workspace as a wireframe; a scene-frame device none.
TEST(RenderScene, PlacedDeviceShowsItsWorkspace) {
  if (!display_available()) GTEST_SKIP() << "no X display (run under xvfb-run -a)";
  SceneSettings settings = quiet_settings();
  settings.tool_glyphs = true;  // the box is drawn with the tool
  Offscreen view(settings);
  LatestState state = live_state();
  state.volume = ball_volume();
  const RgbImage without = view.draw(state);
  EXPECT_FALSE(view.scene->workspace_visible());
  auto scene = std::make_shared<SceneDescription>(*state.scene);
  SceneDescription::Placement p;
  p.workspace_half_mm = {15, 15, 15};
  p.home = {kCentre, kCentre, kCentre + kRadius + 20};
  p.home_skin = {kCentre, kCentre, kCentre + kRadius};
  p.home_site = "auto";
  p.axes = "LPS";
  scene->placement = p;
  state.scene = scene;
  const RgbImage with = view.draw(state);
  EXPECT_TRUE(view.scene->workspace_visible());
  std::size_t changed = 0;
  for (std::size_t i = 0; i < with.rgb.size(); ++i) changed += with.rgb[i] != without.rgb[i];
  EXPECT_GT(changed, 50u);
}

// A volume whose arrays do not match its dimensions is refused and never sampled (the shadow and
// the deformer index by the dimensions): no volume, no crash, and a good one after it loads.
TEST(RenderScene, VolumeWithMismatchedArraysIsRefused) {
  if (!display_available()) GTEST_SKIP() << "no X display (run under xvfb-run -a)";
  SceneSettings settings = quiet_settings();
  settings.tool_glyphs = true;  // the shadow samples the volume
  Offscreen view(settings);
  LatestState state = live_state();
  auto bad = std::make_shared<RenderVolume>(*ball_volume());
  bad->d_surf.resize(bad->d_surf.size() / 2);
  state.volume = bad;
  view.draw(state);
  EXPECT_FALSE(view.scene->has_volume());
  auto bad_bone = std::make_shared<RenderVolume>(*ball_volume());
  bad_bone->d_bone.assign(3, 1.0f);
  state.volume = bad_bone;
  view.draw(state);
  EXPECT_FALSE(view.scene->has_volume());
  state.volume = ball_volume();
  view.draw(state);
  EXPECT_TRUE(view.scene->has_volume());
}

TEST(RenderScene, PressingDeformsTheSkinInsideTheRoiOnly) {
  if (!display_available()) GTEST_SKIP() << "no X display (run under xvfb-run -a)";
  Offscreen view(quiet_settings());
  const auto volume = ball_volume();
  LatestState resting = pressed_state(volume, -20.0);  // same tool, 20 mm in front of the skin
  ASSERT_EQ(resting.frame.n_contact, 0u);
  const RgbImage before = view.draw(resting);
  EXPECT_FALSE(view.last_deform.active);
  const LatestState pressed = pressed_state(volume, 6.0);
  ASSERT_EQ(pressed.frame.n_contact, 37u);
  const RgbImage after = view.draw(pressed);
  const DeformResult roi = view.last_deform;
  ASSERT_TRUE(roi.active);
  // The ROI's screen rectangle: its voxel box grown by two voxels (trilinear sampling and the
  // shading gradient reach one voxel each beyond it), all eight corners projected.
  double x_lo = 1e9, x_hi = -1e9, y_lo = 1e9, y_hi = -1e9;
  for (int c = 0; c < 8; ++c) {
    Vec3d corner;
    double* axes[3] = {&corner.x, &corner.y, &corner.z};
    for (int a = 0; a < 3; ++a) {
      const std::int64_t v = (c >> a) & 1 ? roi.hi[a] - 1 + 2 : roi.lo[a] - 2;
      *axes[a] = kSpacing * static_cast<double>(v);
    }
    const auto d = view.scene->to_display(corner);
    x_lo = std::min(x_lo, d[0]), x_hi = std::max(x_hi, d[0]);
    y_lo = std::min(y_lo, d[1]), y_hi = std::max(y_hi, d[1]);
  }
  std::size_t changed_inside = 0, changed_outside = 0;
  int worst_outside = 0;
  for (int y = 0; y < kSize; ++y)
    for (int x = 0; x < kSize; ++x) {
      const bool inside = x + 1 >= x_lo && x <= x_hi && y + 1 >= y_lo && y <= y_hi;
      const int d = pixel_difference(before, after, x, y);
      if (inside) {
        changed_inside += d > 8;
      } else {
        changed_outside += d > 0;
        worst_outside = std::max(worst_outside, d);
      }
    }
  EXPECT_GT(changed_inside, 20u) << "ROI " << x_lo << ".." << x_hi << " x " << y_lo << ".." << y_hi;
  EXPECT_EQ(changed_outside, 0u) << "worst difference outside the ROI: " << worst_outside;
  // Only the written box went to the texture (a sub-volume upload), not the whole volume.
  const std::int64_t box = (roi.hi[0] - roi.lo[0]) * (roi.hi[1] - roi.lo[1]) *
                           (roi.hi[2] - roi.lo[2]) * static_cast<std::int64_t>(sizeof(float));
  EXPECT_EQ(view.scene->last_upload_bytes(), box);
  EXPECT_LT(box, kDim * kDim * kDim * static_cast<std::int64_t>(sizeof(float)) / 10);

  // Releasing restores the original scalars and image exactly.
  const RgbImage released = view.draw(resting);
  EXPECT_EQ(view.scene->render_scalars(),
            compose_skin_scalar(volume->d_surf, volume->dims, volume->spacing));
  EXPECT_EQ(differing_pixels(before, released), 0u);
}

// The ball as a CT: soft tissue (40 HU) inside the body mask, air outside, and a "rib": a bar
// of 700 HU, 4 mm thick, 6 mm under the front skin, across x at the ball's centre height.
std::shared_ptr<const RenderVolume> ct_ball_volume() {
  auto v = std::make_shared<RenderVolume>(*ball_volume());
  const std::size_t n = v->d_surf.size();
  v->hu.assign(n, -1000);
  v->body.assign(n, 0);
  for (std::int64_t k = 0; k < kDim; ++k)
    for (std::int64_t j = 0; j < kDim; ++j)
      for (std::int64_t i = 0; i < kDim; ++i) {
        const auto at = static_cast<std::size_t>((k * kDim + j) * kDim + i);
        if (v->d_surf[at] < 0) continue;
        v->body[at] = 1;
        const double y = kSpacing * j, z = kSpacing * k;
        const bool rib =
            std::abs(y - (kCentre - kRadius + 8.0)) <= 2.0 && std::abs(z - kCentre) <= 4.0;
        v->hu[at] = rib ? 700 : 40;
      }
  return v;
}

// Where along the press line (x, z at the centre) the rib is brightest: its y voxel.
std::int64_t rib_voxel(const std::vector<float>& scalars) {
  const std::int64_t c = static_cast<std::int64_t>(kCentre / kSpacing + 0.5);
  std::int64_t best = 0;
  for (std::int64_t j = 0; j < kDim; ++j)
    if (scalars[static_cast<std::size_t>((c * kDim + j) * kDim + c)] >
        scalars[static_cast<std::size_t>((c * kDim + best) * kDim + c)])
      best = j;
  return best;
}

TEST(RenderScene, TheCtsOwnTextureIsDisplacedUnderAPress) {
  if (!display_available()) GTEST_SKIP() << "no X display (run under xvfb-run -a)";
  SceneSettings settings = quiet_settings();
  settings.preset = PresetId::Bone;
  Offscreen view(settings);
  const auto volume = ct_ball_volume();
  const RgbImage before = view.draw(pressed_state(volume, -20.0));
  // Outside the body mask the HU are replaced by air: nothing there is drawn.
  EXPECT_EQ(view.scene->render_scalars()[0], kOutsideValue);
  const std::int64_t rib_before = rib_voxel(view.scene->render_scalars());
  const RgbImage after = view.draw(pressed_state(volume, 6.0));
  ASSERT_TRUE(view.last_deform.active);
  const std::int64_t rib_after = rib_voxel(view.scene->render_scalars());
  std::printf("rib at y voxel %lld before, %lld pressed (%.0f mm inwards)\n",
              static_cast<long long>(rib_before), static_cast<long long>(rib_after),
              kSpacing * static_cast<double>(rib_after - rib_before));
  EXPECT_GE(rib_after, rib_before + 1) << "the rib did not move inwards under the press";
  EXPECT_GT(differing_pixels(before, after), 20u);
}

TEST(RenderScene, PresetsGiveDifferentImages) {
  if (!display_available()) GTEST_SKIP() << "no X display (run under xvfb-run -a)";
  Offscreen view(quiet_settings());
  LatestState state = live_state();
  state.volume = ball_volume();
  std::vector<RgbImage> images;
  for (PresetId id : {PresetId::Skin, PresetId::Bone, PresetId::Soft}) {
    view.scene->set_preset(id);
    images.push_back(view.draw(state));
  }
  const std::size_t area = kSize * kSize;
  EXPECT_GT(differing_pixels(images[0], images[1]), area / 20);
  EXPECT_GT(differing_pixels(images[0], images[2]), area / 20);
  EXPECT_GT(differing_pixels(images[1], images[2]), area / 20);
  // Windowing changes the image too, and going back restores it.
  view.scene->set_preset(PresetId::Skin);
  view.scene->adjust_window(400.0, 1.0);
  const RgbImage shifted = view.draw(state);
  EXPECT_GT(differing_pixels(images[0], shifted), 0u);
  view.scene->adjust_window(-400.0, 1.0);
  EXPECT_EQ(differing_pixels(images[0], view.draw(state)), 0u);
}

TEST(RenderScene, GlyphsAndHudFollowTheState) {
  if (!display_available()) GTEST_SKIP() << "no X display (run under xvfb-run -a)";
  SceneSettings settings;
  settings.camera_elevation_deg = 20.0;
  Offscreen view(settings);
  const auto volume = ball_volume();
  LatestState state = pressed_state(volume, -20.0);
  state.frame.force = {0, -5, 0};
  const RgbImage with_tool = view.draw(state);
  view.scene->set_tool_glyphs_visible(false);
  const RgbImage without_tool = view.draw(state);
  EXPECT_GT(differing_pixels(with_tool, without_tool), 30u);
  state.link.state = LinkState::Stalled;
  state.link.since_last_frame_s = 2.0;
  view.draw(state);
  EXPECT_EQ(view.scene->last_banner_text(), "STREAM STALLED: no frame for 2.0 s");
  EXPECT_NE(view.scene->last_hud_text().find("link stalled"), std::string::npos);
}

}  // namespace
}  // namespace palp::view
