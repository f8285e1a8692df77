// The realtime loop on a manual clock: a tracker's measurement cycles fed sample by sample, the
// frames every sink receives recorded. Checks the stale repeat of a silent source (when, how
// often, to which sinks), the cycle wait for a missing sensor, and that a pass allocates nothing.
#include <gtest/gtest.h>

#include <array>
#include <memory>

#include "mimic/core/alloc_counter.h"
#include "mimic/core/clock.h"
#include "mimic/net/frame_codec.h"
#include "mimic/service/pipeline.h"
#include "mimic/service/sink.h"
#include "mimic/solver/sensor_layout.h"

namespace pipeline_test {

namespace {

using namespace mimic;
using namespace mimic::service;

// A tracker whose records the test hands over: each sits in a fixed ring until polled (no
// allocation), carrying the host time the test gives it.
class ScriptedTracker final : public devices::SensorSource {
 public:
  struct Shared {
    std::array<devices::SensorSample, 256> ring{};
    size_t head = 0, tail = 0;
  };
  explicit ScriptedTracker(std::shared_ptr<Shared> shared) : shared_(std::move(shared)) {}
  Status start() override { return {}; }
  size_t poll(std::span<devices::SensorSample> out) override {
    size_t n = 0;
    while (n < out.size() && shared_->tail != shared_->head) out[n++] = shared_->ring[shared_->tail++ % 256];
    return n;
  }
  devices::DeviceStatus status() const override { return {}; }
  void stop() override {}

 private:
  std::shared_ptr<Shared> shared_;
};

// What each sink got, in fixed storage (send() must not allocate, and neither may the test's).
class RecordingSink final : public PoseSink {
 public:
  struct Frame {
    uint32_t sequence = 0;
    uint16_t flags = 0;
    uint64_t time_us = 0;
    size_t packet_bytes = 0, samples = 0;
    bool stale_repeat = false;
  };
  RecordingSink(bool forwards_stale, bool wants_mesh) : forwards_stale_(forwards_stale), wants_mesh_(wants_mesh) {}
  const char* name() const noexcept override { return "recording"; }
  bool forwards_stale_repeats() const noexcept override { return forwards_stale_; }
  Status add_avatar(AvatarJoin&) override { return {}; }
  bool send(const FrameOut& f) noexcept override {
    if (count < frames.size())
      frames[count] = {f.header.sequence, f.header.flags,   f.header.time_us,
                       f.packet.size(),   f.samples.size(), f.stale_repeat};
    ++count;
    return true;
  }
  bool wants_mesh(size_t, uint8_t) const noexcept override { return wants_mesh_; }
  bool send_mesh(const MeshOut& m) noexcept override {
    ++meshes;
    mesh_bytes = m.packet.size();
    return true;
  }
  const Frame& last() const { return frames[std::min(count, frames.size()) - 1]; }

  std::array<Frame, 64> frames{};
  size_t count = 0, meshes = 0, mesh_bytes = 0;

 private:
  bool forwards_stale_, wants_mesh_;
};

struct Rig {
  std::shared_ptr<ManualClock> clock = std::make_shared<ManualClock>(100.0);
  std::shared_ptr<ScriptedTracker::Shared> tracker = std::make_shared<ScriptedTracker::Shared>();
  RecordingSink* stream = nullptr;     // forwards stale repeats (as the scene server does)
  RecordingSink* live_only = nullptr;  // does not (as VMC and VRPN)
  std::unique_ptr<Pipeline> pipeline;
  std::vector<devices::SensorSample> cycle;  // the six sensors of the standard layout at rest

  explicit Rig(bool with_skin = false) {
    auto body = load_body("");
    EXPECT_TRUE(body.has_value());
    auto skeleton = rig::Skeleton::build(body->model.skeleton);
    EXPECT_TRUE(skeleton.has_value());
    // The records a tracker worn in the standard six-sensor layout sends at rest.
    auto layout = solver::standard_layout("6", *skeleton);
    EXPECT_TRUE(layout.has_value());
    std::vector<rig::RigidTransform> joints(size_t(skeleton->joint_count()));
    rig::forward_kinematics(*skeleton, skeleton->rest_pose(), joints);
    for (const auto& b : layout->bindings) {
      const rig::RigidTransform& seg = joints[size_t(skeleton->find_joint(b.segment))];
      devices::SensorSample s;
      s.sensor = b.sensor;
      s.position_m = seg.apply(b.placement_m);
      s.orientation = seg.rotation;
      cycle.push_back(s);
    }
    SinkList sinks;
    auto a = std::make_unique<RecordingSink>(true, with_skin);
    auto b = std::make_unique<RecordingSink>(false, false);
    stream = a.get();
    live_only = b.get();
    sinks.push_back(std::move(a));
    sinks.push_back(std::move(b));
    pipeline = std::make_unique<Pipeline>(std::move(sinks), clock);
    auto feed = make_tracker_feed(std::make_unique<ScriptedTracker>(tracker), *skeleton, "6", "scripted");
    EXPECT_TRUE(feed.has_value());
    std::unique_ptr<Deformer> deformer;
    if (with_skin) {
      auto skin = make_skin_deformer(body->model, (*feed)->skeleton(), 3);
      EXPECT_TRUE(skin.has_value());
      deformer = std::move(*skin);
    }
    EXPECT_TRUE(pipeline->add_avatar("a", std::move(*feed), body->bytes, std::move(deformer)));
  }
  // Records of the sensors in [first, last) with host time `host_s`.
  void deliver(size_t first, size_t last, double host_s) {
    for (size_t i = first; i < last; ++i) {
      devices::SensorSample s = cycle[i];
      s.host_time_s = host_s;
      s.device_time_s = host_s;
      tracker->ring[tracker->head++ % 256] = s;
    }
  }
  void deliver_cycle(double host_s) { deliver(0, cycle.size(), host_s); }
};

TEST(Pipeline, ASilentSourceRepeatsItsLastPoseFlaggedStaleToTheSinksThatForwardRepeats) {
  Rig rig;
  rig.deliver_cycle(100.0);
  rig.pipeline->tick();
  ASSERT_EQ(rig.stream->count, 1u);
  ASSERT_EQ(rig.live_only->count, 1u);
  const RecordingSink::Frame first = rig.stream->last();
  EXPECT_FALSE(first.stale_repeat);
  EXPECT_EQ(first.flags & net::kPoseStale, 0);
  EXPECT_GT(first.packet_bytes, 0u);
  EXPECT_EQ(first.samples, 6u);  // the samples the pose was solved from go along

  // Quiet for less than the documented time: nothing goes out.
  rig.clock->advance(0.5 * Pipeline::kStaleRepeat_s);
  rig.pipeline->tick();
  EXPECT_EQ(rig.stream->count, 1u);
  EXPECT_EQ(rig.pipeline->silent_sources(), 0u);

  // kStaleRepeat_s after the last frame: the last pose again, flagged stale, with the capture
  // time of the data it shows; not to the sink that does not forward repeats.
  rig.clock->advance(0.5 * Pipeline::kStaleRepeat_s + 1e-6);
  rig.pipeline->tick();
  ASSERT_EQ(rig.stream->count, 2u);
  EXPECT_TRUE(rig.stream->last().stale_repeat);
  EXPECT_NE(rig.stream->last().flags & net::kPoseStale, 0);
  EXPECT_EQ(rig.stream->last().sequence, first.sequence + 1);
  EXPECT_EQ(rig.stream->last().time_us, first.time_us);
  EXPECT_EQ(rig.live_only->count, 1u);
  EXPECT_EQ(rig.pipeline->silent_sources(), 1u);
  EXPECT_EQ(rig.pipeline->stale_frames(), 1u);

  // At that lower rate, not every pass.
  rig.pipeline->tick();
  rig.clock->advance(0.9 * Pipeline::kStaleRepeat_s);
  rig.pipeline->tick();
  EXPECT_EQ(rig.stream->count, 2u);
  rig.clock->advance(0.1 * Pipeline::kStaleRepeat_s + 1e-6);
  rig.pipeline->tick();
  EXPECT_EQ(rig.stream->count, 3u);
  EXPECT_EQ(rig.pipeline->stale_frames(), 2u);

  // The source speaks again: a fresh frame, to every sink, and it no longer counts as silent.
  rig.deliver_cycle(rig.clock->now_s());
  rig.pipeline->tick();
  EXPECT_EQ(rig.stream->count, 4u);
  EXPECT_FALSE(rig.stream->last().stale_repeat);
  EXPECT_EQ(rig.live_only->count, 2u);
  EXPECT_EQ(rig.pipeline->silent_sources(), 0u);
  EXPECT_EQ(rig.pipeline->frames(), 2u);
}

TEST(Pipeline, OnePosePerMeasurementCycleAndAMissingSensorWaitsTheCycleWait) {
  Rig rig;
  rig.deliver_cycle(100.000);
  rig.pipeline->tick();
  ASSERT_EQ(rig.stream->count, 1u);

  // A cycle delivered record by record over several passes: one pose, when the last arrives.
  rig.deliver(0, 3, 100.010);
  rig.pipeline->tick();
  EXPECT_EQ(rig.stream->count, 1u);
  rig.deliver(3, 6, 100.011);
  rig.pipeline->tick();
  EXPECT_EQ(rig.stream->count, 2u);

  // Sensor 6 (index 5) stays away: the others wait for it, up to kCycleWait_s of sample time
  // after the first new record, then the pose goes without it.
  rig.deliver(0, 5, 100.020);
  rig.pipeline->tick();
  EXPECT_EQ(rig.stream->count, 2u);
  rig.deliver(0, 1, 100.020 + 0.8 * kCycleWait_s);
  rig.pipeline->tick();
  EXPECT_EQ(rig.stream->count, 2u);
  rig.deliver(0, 1, 100.020 + kCycleWait_s + 1e-4);
  rig.pipeline->tick();
  EXPECT_EQ(rig.stream->count, 3u);
  EXPECT_FALSE(rig.stream->last().stale_repeat);

  // Complete cycles go at once, whatever the clock says.
  rig.deliver_cycle(100.060);
  rig.pipeline->tick();
  EXPECT_EQ(rig.stream->count, 4u);
  EXPECT_EQ(rig.pipeline->frames(), 4u);
}

TEST(Pipeline, APassAllocatesNothingWithFramesStaleRepeatsAndMeshFrames) {
  Rig rig(/*with_skin=*/true);
  double host_s = 100.0;
  auto pass = [&](bool fresh) {
    if (fresh) rig.deliver_cycle(host_s);
    host_s += 0.011;
    rig.clock->set(host_s);
    rig.pipeline->tick();
  };
  for (int i = 0; i < 20; ++i) pass(i % 5 != 4);  // warm-up: every buffer sized
  const uint64_t before = thread_allocation_count();
  for (int i = 0; i < 200; ++i) pass(i % 40 < 30);  // stretches of silence: stale repeats
  const uint64_t allocations = thread_allocation_count() - before;
  EXPECT_EQ(allocations, 0u);
  EXPECT_GT(rig.pipeline->stale_frames(), 0u);
  EXPECT_GT(rig.stream->meshes, 100u);  // a mesh frame per fresh pose, to the sink that asked
  EXPECT_GT(rig.stream->mesh_bytes, 0u);
  EXPECT_EQ(rig.live_only->meshes, 0u);
}

}  // namespace

}  // namespace pipeline_test
