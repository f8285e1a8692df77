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

// What the two receiver sources share: the socket, the clock the stale time is read on, and
// the counters; a tracked pose becomes a sample when it changed since it was last handed out.
class ReceiverSource : public devices::SensorSource {
 public:
  ReceiverSource(std::unique_ptr<net::VmcReceiver> rx, std::shared_ptr<const Clock> clock, double stale_s,
                 std::string description)
      : rx_(std::move(rx)), clock_(std::move(clock)), stale_s_(stale_s), description_(std::move(description)) {}
  Status start() override { return {}; }
  void stop() override {}

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

 protected:
  void rename(std::string description) { description_ = std::move(description); }
  // `pose` as sensor `id` into `out` when it changed since `emitted_s` (then updated).
  bool emit(const net::TrackedPose& pose, int id, double& emitted_s, devices::SensorSample& out) {
    if (!pose.present || pose.received_s == emitted_s) return false;
    emitted_s = pose.received_s;
    out = {};
    out.sensor = static_cast<uint16_t>(id);
    out.device_time_s = out.host_time_s = pose.received_s;
    out.position_m = pose.position_m;
    out.orientation = pose.orientation;
    last_s_ = pose.received_s;
    ++samples_;
    return true;
  }

  std::unique_ptr<net::VmcReceiver> rx_;

 private:
  std::shared_ptr<const Clock> clock_;
  double stale_s_;
  std::string description_;
  double last_s_ = 0;
  uint64_t samples_ = 0;
};

class OscTrackerSource final : public ReceiverSource {
 public:
  OscTrackerSource(std::unique_ptr<net::VmcReceiver> rx, std::array<bool, net::kOscTrackers> worn,
                   std::shared_ptr<const Clock> clock, double stale_s)
      : ReceiverSource(std::move(rx), std::move(clock), stale_s, std::string()), worn_(worn) {
    rename("osc-trackers:" + rx_->endpoint() + " (VRChat OSC trackers)");
  }

  size_t poll(std::span<devices::SensorSample> out) override {
    rx_->poll();
    size_t k = 0;
    const auto& trackers = rx_->state().osc_trackers;
    for (size_t i = 0; i < trackers.size() && k < out.size(); ++i)
      if (worn_[i] && emit(trackers[i], int(i), emitted_s_[i], out[k])) ++k;
    return k;
  }

 private:
  std::array<bool, net::kOscTrackers> worn_;
  std::array<double, net::kOscTrackers> emitted_s_{};
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

class VmcDeviceSource final : public ReceiverSource {
 public:
  VmcDeviceSource(std::unique_ptr<net::VmcReceiver> rx, std::vector<std::string> serials,
                  std::shared_ptr<const Clock> clock, double stale_s)
      : ReceiverSource(std::move(rx), std::move(clock), stale_s, std::string()),
        serials_(std::move(serials)),
        emitted_s_(serials_.size(), 0.0) {
    rename("vmc:" + rx_->endpoint() + " (VMC devices: " + std::to_string(serials_.size()) + ")");
  }

  size_t poll(std::span<devices::SensorSample> out) override {
    rx_->poll();
    const auto& st = rx_->state();
    size_t k = 0;
    for (size_t d = 0; d < st.device_count && k < out.size(); ++d) {
      const int id = sensor_of(st.devices[d]);
      if (id >= 0 && emit(st.devices[d].pose, id, emitted_s_[size_t(id)], out[k])) ++k;
    }
    return k;
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

  std::vector<std::string> serials_;
  std::vector<double> emitted_s_;
};

double stale_of(const devices::SourceSpec& spec) {
  auto it = spec.params.find("stale_ms");
  return it == spec.params.end() ? 0.25 : std::strtod(it->second.c_str(), nullptr) / 1000.0;
}

}  // namespace

Result<solver::SensorLayout> vmc_device_layout(const devices::SourceSpec& spec, const rig::Skeleton& skeleton) {
  auto map = device_map(spec);
  if (!map) return tl::unexpected(map.error());
  solver::SensorLayout layout;
  layout.name = "map";
  for (size_t i = 0; i < map->size(); ++i) {
    auto b = binding_on((*map)[i].second, static_cast<uint16_t>(i), skeleton);
    if (!b) return fail(b.error().code, "vmc map: " + b.error().message);
    layout.bindings.push_back(std::move(*b));
  }
  return layout;
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

Result<solver::SensorLayout> osc_tracker_layout(const devices::SourceSpec& spec, const rig::Skeleton& skeleton) {
  auto names = assignment(spec);
  if (!names) return tl::unexpected(names.error());
  solver::SensorLayout layout;
  layout.name = spec.params.count("map") > 0 ? "map" : "slimevr";
  for (size_t i = 0; i < names->size(); ++i) {
    if ((*names)[i].empty()) continue;
    auto b = binding_on((*names)[i], static_cast<uint16_t>(i), skeleton);
    if (!b) return fail(b.error().code, "osc-trackers map: " + b.error().message);
    layout.bindings.push_back(std::move(*b));
  }
  return layout;
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
