// The realtime path never allocates: filtering and solving a frame, for every layout, counted
// by the allocation counter this test binary links (mimic/core/alloc_counter.h).
#include <gtest/gtest.h>

#include <random>

#include "mimic/core/alloc_counter.h"
#include "mimic/solver/filters.h"
#include "mimic/solver/steering.h"
#include "synthetic_sensors.h"

namespace mimic::solver::no_allocation_test {
namespace {

TEST(NoAllocation, FilterAndSolveFramesForEveryLayout) {
  const rig::Skeleton s = *rig::Skeleton::build(rig::default_skeleton_desc());
  for (const char* name : {"3", "6", "11", "all"}) {
    const auto layout = *standard_layout(name, s);
    const auto mounts = testing::mounts_for(layout, 0.3f, 4);
    auto model = *SolverModel::create(s, mounts);
    SolverContext ctx(model);
    SensorFilterBank filters(static_cast<int>(mounts.size()));
    Steering steering;
    std::mt19937_64 rng(5);
    std::vector<std::vector<devices::SensorSample>> frames;
    std::vector<devices::SensorSample> tick;
    const rig::Pose a = testing::random_pose(s, rng, 0.4f), b = testing::random_pose(s, rng, 0.4f);
    for (int k = 0; k < 30; ++k) {
      rig::Pose p = a;
      for (int d = 0; d < s.dof_count(); ++d)
        p.dof_rad[d] += (b.dof_rad[d] - a.dof_rad[d]) * static_cast<float>(k) / 30.0f;
      testing::sense(s, p, mounts, tick, &rng, 0.001f, 0.01f, 0.01 * k);
      frames.push_back(tick);
    }
    rig::Pose pose = s.zero_pose();
    devices::InputFrame input;
    input.translation = {0.3f, 0, -0.5f};
    const uint64_t before = thread_allocation_count();
    for (auto& f : frames) {
      filters.process(f);
      SolveJob job{&model, f, &ctx, &pose};
      job.Run();
      steering.update(input, 0.01);
      steering.apply(pose);
    }
    EXPECT_EQ(thread_allocation_count() - before, 0u) << "layout " << name;
  }
}

}  // namespace
}  // namespace mimic::solver::no_allocation_test
