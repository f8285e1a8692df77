// End-to-end: how `mimic view --screenshot` draws the body — materials without hard seams, a
// lighting that weighs both halves of a front view alike, antialiased edges, cameras named
// after the body, and a reference mesh beside it. The built program's PNGs, read back.
#include <gtest/gtest.h>

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <string>

#include "mimic/render/image.h"
#include "run_mimic.h"
#include "test_data.h"

namespace view_look_test {

namespace {

using mimic::test::Outcome;
using mimic::test::run_mimic;

constexpr uint8_t kBackground[3] = {237, 240, 245};  // FrameDesc's default background

std::string temp(const std::string& name) {
  return (std::filesystem::temp_directory_path() / ("mimic_view_look_" + std::to_string(::getpid()) + "_" + name))
      .string();
}

mimic::render::Image shoot(const std::string& name, const std::string& options, std::string* output = nullptr) {
  const std::string out = temp(name);
  const Outcome r = run_mimic("view --screenshot '" + out + "' " + options);
  EXPECT_EQ(r.status, 0) << r.output;
  if (output) *output = r.output;
  auto image = mimic::render::read_png(out);
  EXPECT_TRUE(image) << r.output;
  std::filesystem::remove(out);
  return image ? *image : mimic::render::Image{};
}

int off_background(const uint8_t* p) {
  return std::abs(p[0] - kBackground[0]) + std::abs(p[1] - kBackground[1]) + std::abs(p[2] - kBackground[2]);
}
bool is_body(const mimic::render::Image& im, int x, int y) {
  return x >= 0 && y >= 0 && x < im.width && y < im.height && off_background(im.pixel(x, y)) > 60;
}
int step(const uint8_t* a, const uint8_t* b) {
  return std::max({std::abs(a[0] - b[0]), std::abs(a[1] - b[1]), std::abs(a[2] - b[2])});
}

// The largest colour step between vertically neighbouring pixels inside the figure (both
// pixels, and two more each way, on the body: no silhouette), over the middle 60% of its width
// (the torso and the legs) and its height from below the chin to above the ankles: where the per-part colours stepped
// at the neckline, the waist, under the buttocks and at the knees.
int largest_step_down_the_body(const mimic::render::Image& im, int* at_row = nullptr) {
  const mimic::render::Coverage c = mimic::render::coverage(im, kBackground, 20);
  const int mid = (c.min_x + c.max_x) / 2, half = (c.max_x - c.min_x) / 2, h = c.max_y - c.min_y;
  int largest = 0;
  for (int x = mid - 3 * half / 10; x <= mid + 3 * half / 10; ++x)
    // From under the chin (the head is a seventh of the height: its jaw over the shaded neck is a
    // step of light, not of material) to above the shoes.
    for (int y = c.min_y + h / 6; y < c.min_y + 88 * h / 100;
         ++y) {  // above the shoes: their top is the rigid foot's outline over the shin
      bool inside = true;
      for (int d = -2; d <= 3 && inside; ++d) inside = is_body(im, x, y + d);
      for (int d = -2; d <= 2 && inside; ++d) inside = is_body(im, x + d, y);
      if (!inside) continue;
      const int s = step(im.pixel(x, y), im.pixel(x, y + 1));
      if (s > largest) {
        largest = s;
        if (at_row) *at_row = y;
      }
    }
  return largest;
}

TEST(ViewLook, NoHardColourStepsAcrossTheBody) {
  // Flat colours per part stepped by 80-145 (of 255) from one pixel to the next where parts met
  // (measured 92 lit); the clothes now blend into the skin over 3 cm, a few pixels here.
  const std::string pose = "--pose rest --size 320x400 --no-grid --lod 0 ";
  for (const char* camera : {"front", "back", "three-quarter"}) {
    int row = -1;
    // Lit, from the front and back (a three-quarter view puts the chin over the shaded neck: a
    // step of light, not of material).
    if (std::string(camera) != "three-quarter") {
      const int lit = largest_step_down_the_body(shoot("lit.png", pose + "--camera " + camera), &row);
      EXPECT_LT(lit, 70) << camera << ", row " << row;
    }
    // The materials alone (no light): what is left are the garments' soft edges (the neckline seen
    // edge-on from three-quarter steps by 69 on the refitted body; flat colours per part stepped by 92).
    const int albedo =
        largest_step_down_the_body(shoot("albedo.png", pose + "--shading albedo --camera " + camera), &row);
    EXPECT_LT(albedo, 76) << camera << ", row " << row;
  }
  // Clothes there are: the torso's middle is not the colour of the shins.
  const mimic::render::Image im = shoot("albedo.png", pose + "--shading albedo");
  const mimic::render::Coverage c = mimic::render::coverage(im, kBackground, 20);
  const int mid = (c.min_x + c.max_x) / 2, h = c.max_y - c.min_y;
  const uint8_t* chest = im.pixel(mid, c.min_y + 30 * h / 100);
  const uint8_t* hips = im.pixel(mid, c.min_y + 45 * h / 100);
  EXPECT_GT(chest[2], chest[0] + 40) << "a blue top";
  EXPECT_LT(hips[0] + hips[1] + hips[2], 3 * 110) << "dark shorts";
}

TEST(ViewLook, BothHalvesOfAFrontViewAreEquallyBright) {
  // The left side was drawn a shade lighter than the right (1.08 against 0.94) and lit from the
  // left only: 10% brighter. The fill light now balances the key.
  const mimic::render::Image im = shoot("halves.png", "--pose rest --size 320x400 --no-grid --lod 0");
  const mimic::render::Coverage c = mimic::render::coverage(im, kBackground, 20);
  const int mid = (c.min_x + c.max_x) / 2;
  double sum[2] = {0, 0};
  int n[2] = {0, 0};
  for (int y = 0; y < im.height; ++y)
    for (int x = 0; x < im.width; ++x) {
      if (!is_body(im, x, y) || x == mid) continue;
      const uint8_t* p = im.pixel(x, y);
      sum[x > mid] += (p[0] + p[1] + p[2]) / 3.0;
      ++n[x > mid];
    }
  ASSERT_GT(n[0], 1000);
  ASSERT_GT(n[1], 1000);
  const double left = sum[0] / n[0], right = sum[1] / n[1];
  EXPECT_NEAR(left / right, 1.0, 0.04) << left << " against " << right;
}

TEST(ViewLook, EdgesAreAntialiased) {
  // Multisampled and resolved before the read: the silhouette's pixels blend the body into the
  // background instead of being one or the other.
  const mimic::render::Image im = shoot("edges.png", "--pose rest --size 320x400 --no-grid --lod 0 --shading albedo");
  int blended = 0, silhouette = 0;
  for (int y = 1; y + 1 < im.height; ++y)
    for (int x = 1; x + 1 < im.width; ++x) {
      const int off = off_background(im.pixel(x, y));
      if (off == 0) continue;
      const bool edge = off_background(im.pixel(x - 1, y)) == 0 || off_background(im.pixel(x + 1, y)) == 0 ||
                        off_background(im.pixel(x, y - 1)) == 0 || off_background(im.pixel(x, y + 1)) == 0;
      if (!edge) continue;
      ++silhouette;
      blended += off < 150;  // every unlit material lies 180+ away from the background
    }
  ASSERT_GT(silhouette, 300);
  EXPECT_GT(blended, silhouette / 6) << blended << " of " << silhouette;
}

TEST(ViewLook, AmbientOcclusionDarkensCreasesAndNothingElse) {
  // The forearm bent across the belly, the legs together at the thighs: with the screen-space
  // occlusion, the hidden parts darken; no pixel gets brighter, and most of the body is as it was.
  const std::string pose =
      "--pose rest --set l_elbow_flexion=1.5 --size 320x400 --no-grid --lod 0 --camera three-quarter";
  const mimic::render::Image with = shoot("ao.png", pose);
  const mimic::render::Image without = shoot("no_ao.png", pose + " --no-ao");
  ASSERT_EQ(with.rgba.size(), without.rgba.size());
  int darker = 0, brighter = 0, body = 0;
  for (int y = 0; y < with.height; ++y)
    for (int x = 0; x < with.width; ++x) {
      if (!is_body(without, x, y)) continue;
      ++body;
      const uint8_t *a = with.pixel(x, y), *b = without.pixel(x, y);
      const int d = (a[0] + a[1] + a[2]) - (b[0] + b[1] + b[2]);
      darker += d < -9;
      brighter += d > 9;
    }
  EXPECT_GT(darker, 200) << "of " << body;
  EXPECT_LT(darker, body / 3);
  EXPECT_LT(brighter, 10);
}

TEST(ViewLook, TheFloorShowsAContactShadowUnderTheFeet) {
  // With the floor (the grid) drawn: darker under the feet than beside them; the floor's far
  // side is untouched.
  const mimic::render::Image im = shoot("shadow.png", "--pose rest --size 320x400 --lod 0 --camera three-quarter");
  const mimic::render::Coverage c = mimic::render::coverage(im, kBackground, 60);
  auto brightness = [&](int x, int y) {
    const uint8_t* p = im.pixel(x, y);
    return (p[0] + p[1] + p[2]) / 3;
  };
  // Just below the lowest body pixel (the soles' front), and far to the side at that row.
  int darkest = 255;
  for (int x = c.min_x; x <= c.max_x; ++x)
    darkest = std::min(darkest, brightness(x, std::min(c.max_y + 3, im.height - 1)));
  EXPECT_LT(darkest, 200);
  EXPECT_GT(brightness(4, std::min(c.max_y + 3, im.height - 1)), 215);
}

TEST(ViewLook, CameraPresetsFollowTheBodysSides) {
  // The left arm raised: seen from the body's left it is nearest the camera and in the middle
  // of the figure; from its right, hidden behind the body's middle too; from the top, the
  // figure is short (the body is foreshortened to its footprint and shoulders).
  const std::string pose = "--pose rest --set l_shoulder_abduction=1.2 --size 320x360 --no-grid --lod 2 --camera ";
  const mimic::render::Coverage front = mimic::render::coverage(shoot("f.png", pose + "front"), kBackground, 20);
  const mimic::render::Coverage left = mimic::render::coverage(shoot("l.png", pose + "left"), kBackground, 20);
  const mimic::render::Coverage right = mimic::render::coverage(shoot("r.png", pose + "right"), kBackground, 20);
  const mimic::render::Coverage top = mimic::render::coverage(shoot("t.png", pose + "top"), kBackground, 20);
  EXPECT_LT(left.max_x - left.min_x, 0.7 * (front.max_x - front.min_x)) << "side on: narrower";
  EXPECT_LT(right.max_x - right.min_x, 0.7 * (front.max_x - front.min_x)) << "side on: narrower";
  EXPECT_LT(top.max_y - top.min_y, 0.6 * (front.max_y - front.min_y)) << "from above: foreshortened";
}

TEST(ViewLook, CompareObjDrawsTheReferenceMeshBesideTheBody) {
  const std::string obj = mimic::test::shared_data("mesh/makehuman_base_body.obj");
  if (!std::filesystem::exists(obj)) GTEST_SKIP() << obj << " missing (scripts/get-data.sh)";
  std::string output;
  const mimic::render::Image im =
      shoot("compare.png", "--pose rest --size 480x360 --no-grid --lod 1 --compare-obj '" + obj + "'", &output);
  EXPECT_NE(output.find("beside the body"), std::string::npos) << output;
  // Two figures: runs of columns holding figure pixels, apart, the second one grey.
  std::vector<int> column(static_cast<size_t>(im.width), 0);
  for (int y = 0; y < im.height; ++y)
    for (int x = 0; x < im.width; ++x) column[static_cast<size_t>(x)] += is_body(im, x, y);
  int runs = 0;
  std::vector<std::pair<int, int>> spans;
  for (int x = 0; x < im.width; ++x)
    if (column[static_cast<size_t>(x)] > 3 && (x == 0 || column[static_cast<size_t>(x - 1)] <= 3)) {
      ++runs;
      int end = x;
      while (end + 1 < im.width && column[static_cast<size_t>(end + 1)] > 3) ++end;
      spans.emplace_back(x, end);
    }
  ASSERT_EQ(runs, 2) << "two figures, a gap between them";
  // The reference (right) is grey: its pixels' channels close together; the body has skin and a top.
  auto saturated_share = [&](std::pair<int, int> span) {
    int coloured = 0, all = 0;
    for (int y = 0; y < im.height; ++y)
      for (int x = span.first; x <= span.second; ++x) {
        if (!is_body(im, x, y)) continue;
        const uint8_t* p = im.pixel(x, y);
        ++all;
        coloured += std::max({p[0], p[1], p[2]}) - std::min({p[0], p[1], p[2]}) > 40;
      }
    return all ? static_cast<double>(coloured) / all : 0.0;
  };
  EXPECT_GT(saturated_share(spans[0]), 0.5);
  EXPECT_LT(saturated_share(spans[1]), 0.1);
  // Both stand about as tall (1.75 m and MakeHuman's 1.67 m).
  const mimic::render::Coverage c = mimic::render::coverage(im, kBackground, 20);
  EXPECT_GT(c.max_y - c.min_y, 0.6 * im.height);
  // A missing file is a clear failure, not a crash.
  const Outcome missing = run_mimic("view --screenshot '" + temp("x.png") + "' --compare-obj /nonexistent.obj");
  EXPECT_EQ(missing.status, 1) << missing.output;
  EXPECT_NE(missing.output.find("nonexistent.obj"), std::string::npos) << missing.output;
}

}  // namespace

}  // namespace view_look_test
