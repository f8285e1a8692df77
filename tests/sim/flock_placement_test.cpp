#include "mimic/sim/flock_placement.h"

#include <cmath>
#include <memory>
#include <vector>

#include <gtest/gtest.h>

#include "mimic/rig/motion.h"
#include "mimic/rig/skeleton.h"
#include "mimic/sim/sensor_rig.h"

namespace flock_placement_test {

namespace {

using mimic::sim::place_flock_transmitter;

// Every sample of a full lap of a motion, in the placed transmitter's frame.
std::vector<glm::vec3> lap_in_transmitter_frame(const char* motion_name, const char* layout, glm::vec3* placed,
                                                double* needed_m) {
  auto skeleton = mimic::rig::Skeleton::build(mimic::rig::default_skeleton_desc());
  EXPECT_TRUE(skeleton);
  auto motion = mimic::rig::make_builtin_motion(motion_name, *skeleton);
  EXPECT_TRUE(motion);
  std::shared_ptr<const mimic::rig::Motion> shared = std::move(*motion);
  mimic::sim::RigConfig rc;
  rc.sensors = *mimic::sim::make_layout(layout, shared->skeleton());
  rc.rate_hz = 50;
  auto rig = mimic::sim::SensorRig::create(shared, rc);
  EXPECT_TRUE(rig);
  std::vector<mimic::devices::SensorSample> tick(static_cast<size_t>(rig->sensor_count()));
  std::vector<glm::vec3> world;
  while (rig->next_device_time_s() <= shared->duration_s()) {
    rig->step(tick);
    for (int i = 0; i < rig->sensor_count(); ++i) world.push_back(rig->true_world_from_sensor(i).translation);
  }
  const auto placement = place_flock_transmitter(world);
  *placed = placement.world_from_transmitter.translation;
  *needed_m = placement.needed_range_m;
  for (auto& p : world) p -= *placed;
  return world;
}

TEST(FlockPlacement, WalkNeedsTheExtendedRangeAndStaysInFront) {
  glm::vec3 at;
  double needed_m = 0;
  const auto lap = lap_in_transmitter_frame("walk", "11", &at, &needed_m);
  ASSERT_FALSE(lap.empty());
  // The walk circles 1.2 m about the origin: more than the standard 36 in, within 144 in.
  EXPECT_GT(needed_m, mimic::sim::kFlockStandardRange_m);
  EXPECT_LT(needed_m, mimic::sim::kFlockExtendedRange_m);
  double max_axis = 0, min_z = 1e9;
  for (const auto& p : lap) {
    max_axis = std::max({max_axis, double(std::abs(p.x)), double(std::abs(p.y)), double(std::abs(p.z))});
    min_z = std::min(min_z, double(p.z));
  }
  EXPECT_NEAR(max_axis, needed_m, 1e-5);
  EXPECT_NEAR(min_z, 0.1, 1e-5);  // the margin behind the rearmost sample
  EXPECT_NEAR(at.x, 0.0, 0.2);    // centred on the circle across
}

TEST(FlockPlacement, StandingBodyFitsTheStandardRange) {
  glm::vec3 at;
  double needed_m = 0;
  const auto lap = lap_in_transmitter_frame("idle", "6", &at, &needed_m);
  ASSERT_FALSE(lap.empty());
  EXPECT_LT(needed_m, mimic::sim::kFlockStandardRange_m);
  for (const auto& p : lap) EXPECT_GE(p.z, 0.0f);
}

TEST(FlockPlacement, ExtentOfAFewPoints) {
  const std::vector<glm::vec3> pts = {{-1, 0, 2}, {1, 2, 3}, {0, 1, 2.5f}};
  const auto pl = place_flock_transmitter(pts, 0.25);
  EXPECT_FLOAT_EQ(pl.world_from_transmitter.translation.x, 0.0f);
  EXPECT_FLOAT_EQ(pl.world_from_transmitter.translation.y, 1.0f);
  EXPECT_FLOAT_EQ(pl.world_from_transmitter.translation.z, 1.75f);
  EXPECT_NEAR(pl.needed_range_m, 1.25, 1e-6);  // z: 3 - 1.75
  EXPECT_TRUE(place_flock_transmitter({}).needed_range_m == 0);
}

}  // namespace

}  // namespace flock_placement_test
