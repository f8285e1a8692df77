// The renderer drawn offscreen (EGL surfaceless on Mesa's llvmpipe): real pixels, read back.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>

#include "mimic/avatar/body_model.h"
#include "mimic/avatar/skin.h"
#include "mimic/render/avatar_lods.h"
#include "mimic/render/image.h"
#include "mimic/render/offscreen.h"
#include "mimic/render/overlays.h"
#include "mimic/render/renderer.h"

namespace renderer_test {

namespace {

using namespace mimic;

constexpr int kW = 320, kH = 360;

struct Bg {
  uint8_t rgb[3];
};
Bg background_bytes(const glm::vec3& c) {
  Bg b{};
  for (int k = 0; k < 3; ++k) b.rgb[k] = static_cast<uint8_t>(std::lround(c[k] * 255.0f));
  return b;
}

class RendererTest : public ::testing::Test {
 protected:
  void SetUp() override {
    auto ctx = render::OffscreenContext::create(kW, kH);
    ASSERT_TRUE(ctx) << ctx.error().what();
    context_.emplace(std::move(*ctx));
    auto r = render::Renderer::create();
    ASSERT_TRUE(r) << r.error().what();
    renderer_.emplace(std::move(*r));
  }
  render::Image draw(const render::FrameDesc& frame) {
    renderer_->render(frame);
    return context_->read();
  }
  std::optional<render::OffscreenContext> context_;
  std::optional<render::Renderer> renderer_;
};

TEST_F(RendererTest, AnEmptySceneIsEmpty) {
  render::FrameDesc frame;
  frame.width_px = kW;
  frame.height_px = kH;
  frame.grid = false;
  const render::Image image = draw(frame);
  const Bg bg = background_bytes(frame.background);
  EXPECT_EQ(render::coverage(image, bg.rgb, 1).count, 0);
  // The grid lies on the floor: with the camera above it, nothing above the horizon.
  frame.grid = true;
  frame.camera.pitch_rad = 0.3f;
  const render::Image grid = draw(frame);
  const render::Coverage c = render::coverage(grid, bg.rgb, 1);
  EXPECT_GT(c.count, 500);
  EXPECT_GT(c.min_y, kH / 3);
}

TEST_F(RendererTest, TheBodyCoversItsProjectionAndNothingElse) {
  const avatar::BodyModel model = avatar::default_body_model();
  auto lods = render::AvatarLods::create(model, nullptr, *renderer_);
  ASSERT_TRUE(lods) << lods.error().what();
  rig::Pose pose = lods->skeleton().rest_pose();
  pose.root_position_m = {0.3f, rig::standing_root_height_m(lods->skeleton()), -0.5f};
  for (int lod = 0; lod < lods->count(); ++lod) {
    const render::MeshId mesh = lods->update(lod, pose, *renderer_);
    render::FrameDesc frame;
    frame.width_px = kW;
    frame.height_px = kH;
    frame.grid = false;
    frame.camera = render::preset_camera(render::CameraPreset::kThreeQuarter, {0.3f, 0, -0.5f}, 1.7f, float(kW) / kH);
    const render::MeshDraw draw_list[] = {{mesh, glm::mat4(1.0f), 1.0f}};
    frame.meshes = draw_list;
    const render::Image image = draw(frame);
    const Bg bg = background_bytes(frame.background);
    const render::Coverage c = render::coverage(image, bg.rgb, 3);

    // Where the vertices project, in pixels (row 0 at the top).
    const glm::mat4 clip_from_world = frame.camera.clip_from_world(float(kW) / kH);
    glm::vec2 lo(1e9f), hi(-1e9f);
    for (const glm::vec3& p : lods->mesh(lod).positions) {
      const glm::vec4 clip = clip_from_world * glm::vec4(p, 1.0f);
      const glm::vec2 px((clip.x / clip.w * 0.5f + 0.5f) * kW, (0.5f - clip.y / clip.w * 0.5f) * kH);
      lo = glm::min(lo, px);
      hi = glm::max(hi, px);
    }
    EXPECT_NEAR(c.min_x, lo.x, 2.0f) << "LOD " << lod;
    EXPECT_NEAR(c.max_x, hi.x, 2.0f) << "LOD " << lod;
    EXPECT_NEAR(c.min_y, lo.y, 2.0f) << "LOD " << lod;
    EXPECT_NEAR(c.max_y, hi.y, 2.0f) << "LOD " << lod;
    // A solid body, not a wireframe: a large share of its box is covered.
    const double box = (hi.x - lo.x) * (hi.y - lo.y);
    EXPECT_GT(c.count, 0.12 * box) << "LOD " << lod;
  }
}

TEST_F(RendererTest, XrayLinesShowThroughTheBodyAndDepthTestedLinesDoNot) {
  const avatar::BodyModel model = avatar::default_body_model();
  auto lods = render::AvatarLods::create(model, nullptr, *renderer_);
  ASSERT_TRUE(lods);
  rig::Pose pose = lods->skeleton().rest_pose();
  pose.root_position_m.y = rig::standing_root_height_m(lods->skeleton());
  const render::MeshId mesh = lods->update(2, pose, *renderer_);
  render::FrameDesc frame;
  frame.width_px = kW;
  frame.height_px = kH;
  frame.grid = false;
  frame.camera = render::preset_camera(render::CameraPreset::kFront, {0, 0, 0}, 1.7f, float(kW) / kH);
  const render::MeshDraw draw_list[] = {{mesh, glm::mat4(1.0f), 1.0f}};
  frame.meshes = draw_list;
  // A pure green segment through the belly (inside the body, along X).
  render::Lines line;
  line.add({-0.05f, 1.0f, 0.0f}, {0.05f, 1.0f, 0.0f}, {0, 1, 0, 1});
  auto green_pixels = [](const render::Image& image) {
    int n = 0;
    for (int y = 0; y < image.height; ++y)
      for (int x = 0; x < image.width; ++x) {
        const uint8_t* p = image.pixel(x, y);
        n += p[1] > 200 && p[0] < 60 && p[2] < 60;
      }
    return n;
  };
  frame.lines = line.vertices;
  EXPECT_EQ(green_pixels(draw(frame)), 0);
  frame.lines = {};
  frame.xray_lines = line.vertices;
  EXPECT_GT(green_pixels(draw(frame)), 5);
}

// Silhouette pixels that blend the body into the background (neither the one nor the other).
int blended_edge_pixels(const render::Image& image, const glm::vec3& background) {
  const Bg bg = background_bytes(background);
  auto off = [&](int x, int y) {
    const uint8_t* p = image.pixel(x, y);
    return std::abs(p[0] - bg.rgb[0]) + std::abs(p[1] - bg.rgb[1]) + std::abs(p[2] - bg.rgb[2]);
  };
  int n = 0;
  for (int y = 1; y + 1 < image.height; ++y)
    for (int x = 1; x + 1 < image.width; ++x) {
      const int o = off(x, y);
      const bool edge = off(x - 1, y) == 0 || off(x + 1, y) == 0 || off(x, y - 1) == 0 || off(x, y + 1) == 0;
      n += edge && o > 0 && o < 150;  // every unlit material lies 180+ away from the background
    }
  return n;
}

TEST(RendererMsaa, TheDefaultOffscreenFrameIsMultisampledAndResolved) {
  // The same body drawn unlit (its colours alone) into a single-sampled and a 4× frame: only
  // the second has edge pixels between the body and the background.
  int blended[2] = {0, 0};
  for (int samples : {0, 4}) {
    auto ctx = render::OffscreenContext::create(kW, kH, samples);
    ASSERT_TRUE(ctx) << ctx.error().what();
    auto renderer = render::Renderer::create();
    ASSERT_TRUE(renderer) << renderer.error().what();
    auto lods = render::AvatarLods::create(avatar::default_body_model(), nullptr, *renderer);
    ASSERT_TRUE(lods);
    rig::Pose pose = lods->skeleton().rest_pose();
    pose.root_position_m.y = rig::standing_root_height_m(lods->skeleton());
    render::FrameDesc frame;
    frame.width_px = kW;
    frame.height_px = kH;
    frame.grid = false;
    frame.unlit = true;
    frame.camera = render::preset_camera(render::CameraPreset::kFront, {0, 0, 0}, 1.8f, float(kW) / kH);
    const render::MeshDraw draw_list[] = {{lods->update(1, pose, *renderer), glm::mat4(1.0f), 1.0f}};
    frame.meshes = draw_list;
    renderer->render(frame);
    blended[samples > 0] = blended_edge_pixels(ctx->read(), frame.background);
  }
  EXPECT_LT(blended[0], 10) << blended[1];
  EXPECT_GT(blended[1], 150) << blended[0];
}

TEST_F(RendererTest, FramesAreDeterministic) {
  render::FrameDesc frame;
  frame.width_px = kW;
  frame.height_px = kH;
  const render::Image a = draw(frame);
  const render::Image b = draw(frame);
  EXPECT_EQ(a.rgba, b.rgba);
}

TEST(Png, RoundTripsAnImage) {
  render::Image image;
  image.width = 7;
  image.height = 5;
  for (int i = 0; i < 35; ++i)
    for (int k = 0; k < 4; ++k) image.rgba.push_back(k == 3 ? 255 : static_cast<uint8_t>(i * 7 + k * 60));
  const std::string path = (std::filesystem::temp_directory_path() / "mimic_png_roundtrip.png").string();
  ASSERT_TRUE(render::write_png(image, path));
  auto back = render::read_png(path);
  ASSERT_TRUE(back) << back.error().what();
  EXPECT_EQ(back->width, 7);
  EXPECT_EQ(back->height, 5);
  EXPECT_EQ(back->rgba, image.rgba);
  std::filesystem::remove(path);
  EXPECT_FALSE(render::read_png(path));
  EXPECT_FALSE(render::write_png(render::Image{}, path));
}

TEST(Overlays, SensorsShowTheirAxesAndAStaleOneItsBox) {
  render::Lines lines;
  const glm::quat turned = glm::angleAxis(1.5707964f, glm::vec3(0, 0, 1));  // x axis onto +y
  const render::SensorMark fresh{{0, 1, 0}, turned, false}, stale{{1, 1, 0}, glm::quat(1, 0, 0, 0), true};
  render::append_sensors(std::span<const render::SensorMark>(&fresh, 1), lines);
  ASSERT_EQ(lines.vertices.size(), 6u);                     // three axes
  EXPECT_NEAR(lines.vertices[1].position.y, 1.08f, 1e-5f);  // the sensor's x axis, turned up
  EXPECT_GT(lines.vertices[1].color.x, 0.9f);               // drawn red
  lines.clear();
  render::append_sensors(std::span<const render::SensorMark>(&stale, 1), lines);
  EXPECT_EQ(lines.vertices.size(), 6u + 24u);  // and the twelve edges of a box
  EXPECT_EQ(lines.vertices.back().color, glm::vec4(1, 0, 1, 1));
}

TEST(Overlays, ParseNamesAndMeasureMuscles) {
  unsigned mask = 0;
  EXPECT_TRUE(render::parse_overlays("skeleton,rays", mask));
  EXPECT_EQ(mask, render::kOverlaySkeleton | render::kOverlayRays);
  EXPECT_TRUE(render::parse_overlays("all", mask));
  EXPECT_EQ(mask, 0x1fu);
  EXPECT_FALSE(render::parse_overlays("skeleton,bones", mask));
  avatar::Deformation d;
  d.falloff = avatar::Falloff::parabolic;
  rig::Dof dof;
  dof.min_rad = -1.0f;
  dof.max_rad = 2.0f;
  dof.rest_rad = 0.0f;
  EXPECT_FLOAT_EQ(render::deformation_amount(d, dof, 0.0f), 0.0f);
  EXPECT_FLOAT_EQ(render::deformation_amount(d, dof, 1.0f), 0.25f);
  EXPECT_FLOAT_EQ(render::deformation_amount(d, dof, -1.0f), 1.0f);
  EXPECT_FLOAT_EQ(render::deformation_amount(d, dof, 9.0f), 1.0f);
}

}  // namespace

}  // namespace renderer_test
