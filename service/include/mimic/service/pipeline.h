// The realtime pipeline of Mimic: for every avatar, read (poll its tracker source) →
// solve (samples → Pose) → encode (pose frame, once) → send (to every pose sink: scene server,
// remote publisher, NATS, VMC, VRPN), then deform (Pose → skin) and send mesh frames to the
// sinks that ask. The pose frames go first because receivers deform locally: the pose stream
// never waits for the skin. Built at setup; Pipeline::tick() never allocates or throws: a source
// with nothing new is skipped, a failed send is counted.
//
// Seams (replaceable without touching the loop): PoseFeed does read + solve (tracker source +
// body solver), Deformer does deform (the skin at a mesh LOD, or forward kinematics alone when
// nobody asked for meshes), PoseSink does send (service/sink.h), Clock says what time it is (a
// ManualClock in tests). A library of its own so that every front end (`mimic run`, the viewer,
// the tests) runs the same loop; service/scene_builder.h builds the feeds from `--source` specs.
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "mimic/avatar/body_model.h"
#include "mimic/avatar/mesh.h"
#include "mimic/rig/motion.h"
#include "mimic/rig/skeleton.h"
#include "mimic/avatar/realtime_skin.h"
#include "mimic/avatar/skin_lod.h"
#include "mimic/core/clock.h"
#include "mimic/core/result.h"
#include "mimic/devices/sample.h"
#include "mimic/devices/source.h"
#include "mimic/service/sink.h"

namespace mimic::service {

enum Stage { kStageRead, kStageSolve, kStageDeform, kStageEncode, kStageSend, kStageLatency, kStageCount };
const char* stage_name(int stage);

// p50/p99 over the last `window` values; add() never allocates.
class StageTimer {
 public:
  explicit StageTimer(size_t window = 2048) : ring_(window), scratch_(window) {}
  void add(double us);
  struct Summary {
    double p50_us = 0, p99_us = 0, max_us = 0;
    uint64_t count = 0;
  };
  Summary summary();                                 // uses preallocated scratch: no allocation
  void clear() { next_ = filled_ = 0, count_ = 0; }  // e.g. after a warm-up

 private:
  std::vector<float> ring_;
  std::vector<double> scratch_;
  size_t next_ = 0, filled_ = 0;
  uint64_t count_ = 0;
};

// Read + solve for one avatar.
class PoseFeed {
 public:
  virtual ~PoseFeed() = default;
  virtual const rig::Skeleton& skeleton() const = 0;
  virtual std::string describe() const = 0;
  virtual Status start() = 0;
  // Polls the source; the number of new samples ready for a pose (0: nothing new this tick, or
  // a measurement cycle not complete yet).
  virtual size_t read() = 0;
  // The pose from the samples read last. `capture_s` is the host time (steady clock, seconds)
  // at the newest sample's last byte.
  virtual void solve(rig::Pose& pose, double& capture_s, bool& stale) = 0;
  virtual devices::DeviceStatus status() const = 0;
  // The newest sample of every sensor as the last solve() used them (after the filters, in the
  // source's reference frame), for viewers to draw and outputs that pass the trackers on; empty
  // for feeds that do not solve from samples.
  virtual std::span<const devices::SensorSample> latest_samples() const { return {}; }
};

// Pose → skin. The stand-in computes joint frames (what the skin deformer starts from). A
// deformer that produces a mesh returns it from mesh() (same topology every frame, at lod());
// the pipeline then streams mesh frames to subscribers that asked for that LOD.
class Deformer {
 public:
  virtual ~Deformer() = default;
  virtual void deform(const rig::Pose& pose) = 0;
  virtual const avatar::Mesh* mesh() const { return nullptr; }
  virtual uint8_t lod() const { return 0; }
  // The mesh's texture coordinates (its seams split), sent once with the topology; or none.
  virtual const avatar::TextureLayout* texture() const { return nullptr; }
};

// A sensor source on a virtual body following `motion`; the solve stage poses the avatar from
// the motion at the newest sample's device time (ground truth, for measurements).
Result<std::unique_ptr<PoseFeed>> make_motion_feed(std::shared_ptr<const rig::Motion> motion,
                                                   std::unique_ptr<devices::SensorSource> source,
                                                   std::string description);
// Tracker source (sim:, bvh:, replay:, flock: — see sim/open_source.h) + sensor filters + body
// solver. With a calibration file (mimic calibrate), on the wearer's fitted skeleton with the
// measured sensor offsets; otherwise on Mimic's default skeleton, with a simulated rig's exact
// mounts or a tracker's standard-layout placements (sensors=3|6|11|all, default 6).
// `body`, when given (the skeleton of the avatar's body model), replaces the default skeleton:
// simulated sensors ride a performer of that size and the solver solves on it, so a body of
// another size stands on the floor. A calibration's fitted skeleton takes precedence.
Result<std::unique_ptr<PoseFeed>> open_feed(const std::string& spec_text, const std::string& calibration_path = "",
                                            const rig::Skeleton* body = nullptr);

// Tracker samples from `source` through the sensor filters and the body solver on `skeleton`,
// the sensors where the standard layout `layout` (3, 6, 11, all) places them. One pose per
// measurement cycle: when every sensor seen so far has a new sample, or kCycleWait_s (25 ms of
// sample time) after the first new one, when a sensor must be missing.
Result<std::unique_ptr<PoseFeed>> make_tracker_feed(std::unique_ptr<devices::SensorSource> source,
                                                    const rig::Skeleton& skeleton, const std::string& layout,
                                                    std::string description);
inline constexpr double kCycleWait_s = 0.025;

// Built-in motion by name ("walk", "run", "idle").
Result<std::shared_ptr<const rig::Motion>> builtin_motion(const std::string& name, const rig::Skeleton& skeleton);

std::unique_ptr<Deformer> make_fk_deformer(const rig::Skeleton& skeleton);

// The body model of an avatar (the file given with --body, or the default body) and the bytes
// sent to subscribers on join (its compact JSON form, docs/body-model.md).
struct BodyAsset {
  avatar::BodyModel model;
  std::string bytes;
};
Result<BodyAsset> load_body(const std::string& path);

// Mesh levels of detail offered to thin clients: the skin's LODs (avatar/skin_lod.h), 0 the
// body's own contour layout (finest) to 3 (about 300 triangles); contour points are the vertices.
inline constexpr int kMeshLodCount = avatar::kSkinLodCount;
// The skin deformer for `model` on the feed's `skeleton` at `lod`: the realtime method
// (avatar/realtime_skin.h, contours moved) or the full one (avatar/skin.h, contours ray-cast every
// frame); fails when the skeleton lacks the model's joints or DOFs.
Result<std::unique_ptr<Deformer>> make_skin_deformer(const avatar::BodyModel& model, const rig::Skeleton& skeleton,
                                                     int lod, avatar::SkinMethod method = avatar::SkinMethod::realtime);

class Pipeline {
 public:
  // `sinks` receive every frame (none: the poses stay here, for a local viewer); `clock` times
  // the loop (stale repeats, latency, stage timers; default the steady clock). Latency is the
  // clock's now minus the samples' host time: the feeds' sources stamp them on the same clock.
  explicit Pipeline(SinkList sinks = {}, std::shared_ptr<const Clock> clock = nullptr);

  Status add_avatar(const std::string& name, std::unique_ptr<PoseFeed> feed, std::string model_bytes,
                    std::unique_ptr<Deformer> deformer);
  // One pass over every avatar. Never allocates or throws.
  void tick();
  // Between passes of the loop: every sink handles what the network has for it without
  // blocking, then the loop sleeps `idle_us` (a precise sleep: waiting inside the network
  // library rounds up to milliseconds). An error means the remote scene we publish into ended
  // the session.
  Status service_network(int idle_us);

  size_t avatar_count() const { return avatars_.size(); }
  uint64_t frames() const { return frames_; }
  uint64_t send_failures() const { return send_failures_; }
  // Avatars whose source is silent (their last pose repeated, flagged stale, kStaleRepeat_s
  // apart), and how many such repeats went out.
  size_t silent_sources() const { return silent_sources_; }
  uint64_t stale_frames() const { return stale_frames_; }
  static constexpr double kStaleRepeat_s = 0.1;
  StageTimer& timer(int stage) { return timers_[stage]; }
  const PoseFeed& feed(size_t i) const { return *avatars_[i].feed; }
  // The pose avatar i was last solved to (what a local viewer draws).
  const rig::Pose& pose(size_t i) const { return avatars_[i].pose; }

 private:
  struct Avatar {
    std::string name;
    std::unique_ptr<PoseFeed> feed;
    std::unique_ptr<Deformer> deformer;
    rig::Pose pose;
    uint16_t wire_id = 0;  // the avatar's id in pose and mesh frames (AvatarJoin::wire_id)
    uint32_t sequence = 0;
    uint64_t time_us = 0;  // capture time of the current frame
    std::vector<uint8_t> packet;
    std::vector<uint8_t> mesh_packet;  // sized when the topology is announced (add_avatar)
    double last_send_s = 0;            // clock time of the last frame sent
    bool silent = false;               // the source has gone quiet: stale repeats
  };
  void send_mesh(size_t index, Avatar& a);
  // The pose frame encoded in a.packet (`bytes` long, 0 if the encoder refused it) to every sink
  // (the sinks that forward them, for a stale repeat).
  void send_pose(size_t index, Avatar& a, const net::PoseHeader& h, size_t bytes, bool stale_repeat);
  void repeat_stale(size_t index, Avatar& a);
  SinkList sinks_;
  std::shared_ptr<const Clock> clock_;
  std::vector<Avatar> avatars_;
  std::vector<double> pending_latency_;  // capture time of each avatar's frame this pass, or 0
  std::vector<double> pending_send_us_;
  std::array<StageTimer, kStageCount> timers_;
  uint64_t frames_ = 0;
  uint64_t send_failures_ = 0;
  uint64_t stale_frames_ = 0;
  size_t silent_sources_ = 0;
};

}  // namespace mimic::service
