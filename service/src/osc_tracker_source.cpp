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
    const size_t index = key == "head" || key == "0"                         ? 0
                         : key.size() == 1 && key[0] >= '1' && key[0] <= '8' ? size_t(key[0] - '0')
                                                                             : 99;
    if (colon == std::string::npos || colon + 1 == item.size() || index >= out.size())
      return fail(Errc::invalid_argument,
                  "osc-trackers map: expected TRACKER:SEGMENT with TRACKER 1-8 or head, got '" + item + "'");
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
    s.state = samples_ == 0                          ? devices::DeviceState::connecting
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

// (serial, segment) pairs of a vmc: map=.
Result<std::vector<std::pair<std::string, std::string>>> device_map(const devices::SourceSpec& spec) {
  std::vector<std::pair<std::string, std::string>> out;
  auto it = spec.params.find("map");
  if (it == spec.params.end()) return fail(Errc::invalid_argument, "vmc devices: map=SERIAL:SEGMENT,… is needed");
  for (const std::string& item : split_list(it->second)) {
    const size_t colon = item.rfind(':');
    if (colon == std::string::npos || colon == 0 || colon + 1 == item.size())
      return fail(Errc::invalid_argument, "vmc map: expected SERIAL:SEGMENT, got '" + item + "'");
    out.emplace_back(item.substr(0, colon), item.substr(colon + 1));
  }
  if (out.size() > net::kMaxVmcDevices)
    return fail(Errc::invalid_argument, "vmc map: more than " + std::to_string(net::kMaxVmcDevices) + " devices");
  return out;
}

class VmcDeviceSource final : public devices::SensorSource {
 public:
  VmcDeviceSource(std::unique_ptr<net::VmcReceiver> rx, std::vector<std::string> serials,
                  std::shared_ptr<const Clock> clock, double stale_s)
      : rx_(std::move(rx)), serials_(std::move(serials)), clock_(std::move(clock)), stale_s_(stale_s) {
    description_ = "vmc:" + rx_->endpoint() + " (VMC devices: " + std::to_string(serials_.size()) + ")";
    emitted_s_.assign(serials_.size(), 0.0);
  }
  Status start() override { return {}; }
  void stop() override {}

  size_t poll(std::span<devices::SensorSample> out) override {
    rx_->poll();
    const auto& st = rx_->state();
    size_t k = 0;
    for (size_t d = 0; d < st.device_count && k < out.size(); ++d) {
      const auto& dev = st.devices[d];
      const int id = sensor_of(dev);
      if (id < 0 || !dev.pose.present || dev.pose.received_s == emitted_s_[size_t(id)]) continue;
      emitted_s_[size_t(id)] = dev.pose.received_s;
      devices::SensorSample& s = out[k++];
      s = {};
      s.sensor = static_cast<uint16_t>(id);
      s.device_time_s = s.host_time_s = dev.pose.received_s;
      s.position_m = dev.pose.position_m;
      s.orientation = dev.pose.orientation;
      last_s_ = dev.pose.received_s;
      ++samples_;
    }
    return k;
  }

  devices::DeviceStatus status() const override {
    devices::DeviceStatus s;
    s.description = description_;
    s.state = samples_ == 0                          ? devices::DeviceState::connecting
              : clock_->now_s() - last_s_ > stale_s_ ? devices::DeviceState::stale
                                                     : devices::DeviceState::streaming;
    s.records = samples_;
    s.resyncs = rx_->stats().refused_total() + rx_->stats().non_finite;
    return s;
  }

 private:
  // The map item naming this device ("SERIAL", or "T:SERIAL" / "H:SERIAL" / "C:SERIAL"), or -1.
  int sensor_of(const net::VmcState::Device& dev) const {
    const std::string_view serial(dev.serial.data());
    for (size_t i = 0; i < serials_.size(); ++i) {
      std::string_view want = serials_[i];
      if (want.size() > 2 && want[1] == ':') {
        if (want[0] != dev.kind) continue;
        want.remove_prefix(2);
      }
      if (want == serial) return int(i);
    }
    return -1;
  }

  std::unique_ptr<net::VmcReceiver> rx_;
  std::vector<std::string> serials_;
  std::shared_ptr<const Clock> clock_;
  double stale_s_;
  std::string description_;
  std::vector<double> emitted_s_;
  double last_s_ = 0;
  uint64_t samples_ = 0;
};

double stale_of(const devices::SourceSpec& spec) {
  auto it = spec.params.find("stale_ms");
  return it == spec.params.end() ? 0.25 : std::strtod(it->second.c_str(), nullptr) / 1000.0;
}

}  // namespace

Result<std::vector<solver::SensorMount>> vmc_device_mounts(const devices::SourceSpec& spec,
                                                           const rig::Skeleton& skeleton) {
  auto map = device_map(spec);
  if (!map) return tl::unexpected(map.error());
  std::vector<solver::SensorMount> mounts;
  for (size_t i = 0; i < map->size(); ++i) {
    auto m = mount_on((*map)[i].second, static_cast<uint16_t>(i), skeleton);
    if (!m) return fail(m.error().code, "vmc map: " + m.error().message);
    mounts.push_back(std::move(*m));
  }
  return mounts;
}

Result<std::unique_ptr<devices::SensorSource>> open_vmc_device_source(const devices::SourceSpec& spec,
                                                                      std::shared_ptr<const Clock> clock) {
  auto map = device_map(spec);
  if (!map) return tl::unexpected(map.error());
  std::vector<std::string> serials;
  for (auto& [serial, segment] : *map) serials.push_back(serial);
  auto rx = net::VmcReceiver::open(spec.target);
  if (!rx) return tl::unexpected(rx.error());
  if (!clock) clock = std::make_shared<SteadyClock>();
  return std::unique_ptr<devices::SensorSource>(
      new VmcDeviceSource(std::move(*rx), std::move(serials), std::move(clock), stale_of(spec)));
}

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
  const double stale_s = stale_of(spec);
  auto rx = net::VmcReceiver::open(spec.target);
  if (!rx) return tl::unexpected(rx.error());
  if (!clock) clock = std::make_shared<SteadyClock>();
  return std::unique_ptr<devices::SensorSource>(new OscTrackerSource(std::move(*rx), worn, std::move(clock), stale_s));
}

}  // namespace mimic::service
