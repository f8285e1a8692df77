#include "vmc_feed.h"

#include "mimic/core/text.h"

#include "mimic/core/clock.h"
#include "mimic/net/vmc.h"
#include "mimic/net/vmc_receive.h"

namespace mimic::service {

namespace {

class VmcFeed final : public PoseFeed {
 public:
  VmcFeed(rig::Skeleton skeleton, std::unique_ptr<net::VmcReceiver> rx, double stale_after_s)
      : skeleton_(std::move(skeleton)),
        bones_(net::vmc_bone_map(skeleton_)),
        rx_(std::move(rx)),
        stale_after_s_(stale_after_s),
        pose_(skeleton_.rest_pose()) {}
  const rig::Skeleton& skeleton() const override { return skeleton_; }
  std::string describe() const override { return "vmc:" + rx_->endpoint() + " (VMC performer data)"; }
  Status start() override { return {}; }

  // A new frame: the sender's OK (its bundles are all in: a frame is never solved half old,
  // half new), or, from a sender that never sends OK, any new bone.
  size_t read() override {
    rx_->poll();
    const uint64_t frames = rx_->state().frames;
    const uint64_t mark = frames > 0 ? frames : rx_->stats().bones;
    if (mark == seen_) return 0;
    seen_ = mark;
    return 1;
  }

  void solve(rig::Pose& pose, double& capture_s, bool& stale) override {
    const auto& hips = rx_->state().bones[net::kHipsBone];
    const bool ok = net::pose_from_vmc(rx_->state(), skeleton_, bones_, pose_);
    pose.root_position_m = pose_.root_position_m;
    pose.root_orientation = pose_.root_orientation;
    pose.dof_rad.assign(pose_.dof_rad.begin(), pose_.dof_rad.end());  // same size: no allocation
    capture_s = hips.received_s;
    stale = !ok || steady_now_s() - hips.received_s > stale_after_s_;
  }

  devices::DeviceStatus status() const override {
    devices::DeviceStatus s;
    const auto& st = rx_->stats();
    const auto& hips = rx_->state().bones[net::kHipsBone];
    s.description = describe();
    s.state = !hips.present                                       ? devices::DeviceState::connecting
              : steady_now_s() - hips.received_s > stale_after_s_ ? devices::DeviceState::stale
                                                                  : devices::DeviceState::streaming;
    s.records = st.datagrams;
    s.resyncs = st.refused_total() + st.non_finite;
    if (st.refused_total() > 0) s.last_error = "malformed OSC datagrams: " + std::to_string(st.refused_total());
    if (!hips.present) s.last_error = what_else_it_sends();
    return s;
  }

 private:
  // A sender that sends no bones may be sending what another source reads: say which, and how.
  std::string what_else_it_sends() const {
    const net::VmcState& state = rx_->state();
    if (state.device_count > 0) {
      std::string serials;
      for (size_t i = 0; i < state.device_count && i < 4; ++i)
        serials += std::string(serials.empty() ? "" : ", ") + state.devices[i].kind + ":" +
                   terminal_safe(state.devices[i].serial.data());  // the sender's text
      // What to do first: a status line narrower than the message cuts the serials, not the advice.
      return "devices, no bones: use vmc:PORT?map=SERIAL:SEGMENT,... (" + serials + ")";
    }
    if (rx_->stats().osc_tracker_messages > 0) return "VRChat OSC trackers, no bones: use osc-trackers:PORT";
    return {};
  }

  rig::Skeleton skeleton_;
  std::vector<net::VmcBone> bones_;
  std::unique_ptr<net::VmcReceiver> rx_;
  double stale_after_s_;
  rig::Pose pose_;
  uint64_t seen_ = 0;
};

}  // namespace

Result<std::unique_ptr<PoseFeed>> open_vmc_feed(const devices::SourceSpec& spec, const rig::Skeleton* body) {
  auto skeleton = body ? Result<rig::Skeleton>(*body) : rig::Skeleton::build(rig::default_skeleton_desc());
  if (!skeleton) return tl::unexpected(skeleton.error());
  auto rx = net::VmcReceiver::open(spec.target);
  if (!rx) return tl::unexpected(rx.error());
  double stale_after_s = 0.5;
  if (auto it = spec.params.find("stale_ms"); it != spec.params.end()) stale_after_s = std::stod(it->second) / 1000.0;
  return std::unique_ptr<PoseFeed>(new VmcFeed(std::move(*skeleton), std::move(*rx), stale_after_s));
}

}  // namespace mimic::service
