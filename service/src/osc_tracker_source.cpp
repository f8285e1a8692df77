#include "osc_tracker_source.h"

#include <array>
#include <string>

#include "mimic/net/vmc_receive.h"
#include "tracker_map.h"

namespace mimic::service {

namespace {

constexpr std::array<const char*, net::kOscTrackers> kSlimeVrAssignment = {
    "head", "pelvis", "chest", "l_foot", "r_foot", "l_thigh", "r_thigh", "l_upper_arm", "r_upper_arm"};

// Tracker number → segment name ("" when not worn).
Result<std::array<std::string, net::kOscTrackers>> assignment(const devices::SourceSpec& spec) {
  std::array<std::string, net::kOscTrackers> out;
  auto it = spec.params.find("map");
  if (it == spec.params.end()) {
    for (size_t i = 0; i < out.size(); ++i) out[i] = kSlimeVrAssignment[i];
    return out;
  }
  for (const std::string& item : split_list(it->second)) {
    const size_t colon = item.find(':');
    const std::string key = item.substr(0, colon);
    const size_t index = key == "head" || key == "0" ? 0 : key.size() == 1 && key[0] >= '1' && key[0] <= '8' ? size_t(key[0] - '0') : 99;
    if (colon == std::string::npos || colon + 1 == item.size() || index >= out.size())
      return fail(Errc::invalid_argument, "osc-trackers map: expected TRACKER:SEGMENT with TRACKER 1-8 or head, got '" +
                                              item + "'");
    if (!out[index].empty()) return fail(Errc::invalid_argument, "osc-trackers map: tracker " + key + " twice");
    out[index] = item.substr(colon + 1);
  }
  return out;
}

class OscTrackerSource final : public devices::SensorSource {
 public:
  OscTrackerSource(std::unique_ptr<net::VmcReceiver> rx, std::array<bool, net::kOscTrackers> worn,
                   std::shared_ptr<const Clock> clock, double stale_s)
      : rx_(std::move(rx)), worn_(worn), clock_(std::move(clock)), stale_s_(stale_s) {
    description_ = "osc-trackers:" + rx_->endpoint() + " (VRChat OSC trackers)";
  }
  Status start() override { return {}; }
  void stop() override {}

  size_t poll(std::span<devices::SensorSample> out) override {
    rx_->poll();
    size_t k = 0;
    const auto& trackers = rx_->state().osc_trackers;
    for (size_t i = 0; i < trackers.size() && k < out.size(); ++i) {
      const net::TrackedPose& t = trackers[i];
      if (!t.present || !worn_[i] || t.received_s == emitted_s_[i]) continue;
      emitted_s_[i] = t.received_s;
      devices::SensorSample& s = out[k++];
      s = {};
      s.sensor = static_cast<uint16_t>(i);
      s.device_time_s = t.received_s;
      s.host_time_s = t.received_s;
      s.position_m = t.position_m;
      s.orientation = t.orientation;
      last_s_ = t.received_s;
      ++samples_;
    }
    return k;
  }

  devices::DeviceStatus status() const override {
    devices::DeviceStatus s;
    s.description = description_;
    s.state = samples_ == 0                            ? devices::DeviceState::connecting
              : clock_->now_s() - last_s_ > stale_s_ ? devices::DeviceState::stale
                                                       : devices::DeviceState::streaming;
    const auto& st = rx_->stats();
    s.records = samples_;
    s.resyncs = st.refused_total() + st.non_finite;
    if (st.refused_total() > 0) s.last_error = "malformed OSC datagrams: " + std::to_string(st.refused_total());
    return s;
  }

 private:
  std::unique_ptr<net::VmcReceiver> rx_;
  std::array<bool, net::kOscTrackers> worn_;
  std::shared_ptr<const Clock> clock_;
  double stale_s_;
  std::string description_;
  std::array<double, net::kOscTrackers> emitted_s_{};
  double last_s_ = 0;
  uint64_t samples_ = 0;
};

}  // namespace

Result<std::vector<solver::SensorMount>> osc_tracker_mounts(const devices::SourceSpec& spec,
                                                            const rig::Skeleton& skeleton) {
  auto names = assignment(spec);
  if (!names) return tl::unexpected(names.error());
  std::vector<solver::SensorMount> mounts;
  for (size_t i = 0; i < names->size(); ++i) {
    if ((*names)[i].empty()) continue;
    auto m = mount_on((*names)[i], static_cast<uint16_t>(i), skeleton);
    if (!m) return fail(m.error().code, "osc-trackers map: " + m.error().message);
    mounts.push_back(std::move(*m));
  }
  return mounts;
}

Result<std::unique_ptr<devices::SensorSource>> open_osc_tracker_source(const devices::SourceSpec& spec,
                                                                       std::shared_ptr<const Clock> clock) {
  auto names = assignment(spec);
  if (!names) return tl::unexpected(names.error());
  std::array<bool, net::kOscTrackers> worn{};
  for (size_t i = 0; i < worn.size(); ++i) worn[i] = !(*names)[i].empty();
  double stale_s = 0.25;
  if (auto it = spec.params.find("stale_ms"); it != spec.params.end()) stale_s = std::stod(it->second) / 1000.0;
  auto rx = net::VmcReceiver::open(spec.target);
  if (!rx) return tl::unexpected(rx.error());
  if (!clock) clock = std::make_shared<SteadyClock>();
  return std::unique_ptr<devices::SensorSource>(new OscTrackerSource(std::move(*rx), worn, std::move(clock), stale_s));
}

}  // namespace mimic::service
