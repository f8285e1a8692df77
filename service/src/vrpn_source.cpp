#include "vrpn_source.h"

#include <array>
#include <charconv>
#include <cmath>

#include <glm/gtc/quaternion.hpp>

#include "mimic/net/vrpn_client.h"
#include "mimic/solver/sensor_layout.h"
#include "tracker_map.h"

namespace mimic::service {

namespace {

constexpr size_t kMaxSensors = 256;  // VRPN sensor numbers a source maps (Motive/Vicon: rigid bodies)

std::string param(const devices::SourceSpec& spec, const char* key, const char* fallback) {
  auto it = spec.params.find(key);
  return it == spec.params.end() ? fallback : it->second;
}

// (VRPN device index, sensor number) → Mimic sensor id (the solver mount's), or -1 for a sensor
// not worn; index device * kMaxSensors + sensor.
using SensorMap = std::vector<int>;

class VrpnSource final : public devices::SensorSource {
 public:
  VrpnSource(std::unique_ptr<net::VrpnTrackerRemote> remote, std::shared_ptr<const Clock> clock, SensorMap map,
             glm::mat3 axes, float scale_m, double stale_s, std::string description)
      : remote_(std::move(remote)),
        clock_(std::move(clock)),
        map_(std::move(map)),
        axes_(axes),
        scale_m_(scale_m),
        stale_s_(stale_s) {
    status_.description = std::move(description);
    status_.last_error.reserve(256);
  }

  Status start() override { return {}; }
  void stop() override {}

  size_t poll(std::span<devices::SensorSample> out) override {
    size_t nb = 0;
    const size_t n = remote_->poll(reports_, buttons_, nb);
    for (size_t i = 0; i < nb; ++i)
      if (buttons_[i].button >= 0 && buttons_[i].button < 32) {
        const uint32_t bit = 1u << buttons_[i].button;
        button_state_ = buttons_[i].pressed ? button_state_ | bit : button_state_ & ~bit;
      }
    size_t k = 0;
    for (size_t i = 0; i < n && k < out.size(); ++i) {
      const net::VrpnReport& r = reports_[i];
      const size_t at = size_t(r.device) * kMaxSensors + size_t(r.sensor);
      if (r.sensor < 0 || size_t(r.sensor) >= kMaxSensors || at >= map_.size() || map_[at] < 0) continue;
      devices::SensorSample& s = out[k++];
      s = {};
      s.sensor = static_cast<uint16_t>(map_[at]);
      s.device_time_s = r.capture_unix_s;
      s.host_time_s = r.received_s;
      s.position_m = axes_ * glm::vec3(r.position) * scale_m_;
      // The sender's rotation seen in Mimic's axes: M R Mᵀ is a rotation for any signed
      // permutation M, mirrored or not.
      const glm::mat3 rotation = axes_ * glm::mat3_cast(glm::quat(r.orientation)) * glm::transpose(axes_);
      s.orientation = glm::normalize(glm::quat_cast(rotation));
      s.buttons = button_state_;
      s.flags = devices::kSampleValid | (has_buttons() ? devices::kSampleButton : 0u);
      last_sample_s_ = r.received_s;
      ++samples_;
    }
    return k;
  }

  devices::DeviceStatus status() const override {
    devices::DeviceStatus s = status_;
    const auto link = remote_->link();
    const double now = clock_->now_s();
    s.state = link != net::VrpnLink::connected ? (remote_->stats().connects > 0 || !remote_->last_error().empty()
                                                      ? devices::DeviceState::disconnected
                                                      : devices::DeviceState::connecting)
              : samples_ == 0 || now - last_sample_s_ > stale_s_ ? devices::DeviceState::stale
                                                                 : devices::DeviceState::streaming;
    s.records = samples_;
    s.reconnects = remote_->stats().drops;
    s.resyncs = remote_->stats().malformed;
    s.last_error = remote_->last_error();
    return s;
  }

 private:
  bool has_buttons() const { return !remote_->options().button_device.empty(); }

  std::unique_ptr<net::VrpnTrackerRemote> remote_;
  std::shared_ptr<const Clock> clock_;
  SensorMap map_;
  glm::mat3 axes_;
  float scale_m_;
  double stale_s_;
  devices::DeviceStatus status_;
  std::array<net::VrpnReport, 64> reports_{};
  std::array<net::VrpnButtonEvent, 16> buttons_{};
  uint32_t button_state_ = 0;
  double last_sample_s_ = 0;
  uint64_t samples_ = 0;
};

Result<int> parse_int(std::string_view text, int lo, int hi, const std::string& what) {
  int v = 0;
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), v);
  if (text.empty() || ec != std::errc() || end != text.data() + text.size() || v < lo || v > hi)
    return fail(Errc::invalid_argument, what + ": '" + std::string(text) + "' is not a number " + std::to_string(lo) +
                                            "-" + std::to_string(hi));
  return v;
}

// One map= item: a sensor number of the main device, or a device name (its sensor 0).
struct MapItem {
  std::string device;  // empty: the main device
  int sensor = 0;
  std::string segment;
};

// map=0:head,3:pelvis or map=Head:head,LeftHand:l_hand.
Result<std::vector<MapItem>> parse_map(const std::string& text) {
  std::vector<MapItem> out;
  size_t start = 0;
  while (start <= text.size()) {
    size_t comma = text.find(',', start);
    if (comma == std::string::npos) comma = text.size();
    const std::string item = text.substr(start, comma - start);
    const size_t colon = item.find(':');
    if (colon == std::string::npos || colon + 1 == item.size())
      return fail(Errc::invalid_argument, "vrpn map: expected SENSOR:SEGMENT, got '" + item + "'");
    const std::string key = item.substr(0, colon);
    MapItem m;
    m.segment = item.substr(colon + 1);
    if (key.find_first_not_of("0123456789") == std::string::npos) {
      auto sensor = parse_int(key, 0, int(kMaxSensors) - 1, "vrpn map sensor");
      if (!sensor) return tl::unexpected(sensor.error());
      m.sensor = *sensor;
    } else {
      m.device = key;
    }
    for (const auto& o : out)
      if (o.device == m.device && o.sensor == m.sensor)
        return fail(Errc::invalid_argument, "vrpn map: '" + key + "' twice");
    out.push_back(std::move(m));
    start = comma + 1;
  }
  return out;
}

}  // namespace

Result<glm::mat3> parse_axes(const std::string& text) {
  glm::mat3 m(0.0f);
  size_t start = 0;
  bool used[3] = {false, false, false};
  for (int axis = 0; axis < 3; ++axis) {
    size_t comma = text.find(',', start);
    if (comma == std::string::npos) comma = text.size();
    std::string item = text.substr(start, comma - start);
    float sign = 1;
    if (!item.empty() && (item[0] == '-' || item[0] == '+')) {
      sign = item[0] == '-' ? -1.0f : 1.0f;
      item.erase(0, 1);
    }
    const int target = item == "x" ? 0 : item == "y" ? 1 : item == "z" ? 2 : -1;
    if (target < 0 || used[target] || (axis < 2 && comma == text.size()))
      return fail(Errc::invalid_argument,
                  "vrpn axes: expected three signed axes naming x, y and z once each "
                  "(e.g. x,-z,y), got '" +
                      text + "'");
    used[target] = true;
    m[axis][target] = sign;  // column `axis`: where the sender's axis goes
    start = comma + 1;
  }
  if (start <= text.size()) return fail(Errc::invalid_argument, "vrpn axes: more than three axes in '" + text + "'");
  return m;
}

Result<solver::SensorLayout> vrpn_layout(const devices::SourceSpec& spec, const rig::Skeleton& skeleton) {
  if (auto it = spec.params.find("map"); it != spec.params.end()) {
    auto map = parse_map(it->second);
    if (!map) return tl::unexpected(map.error());
    solver::SensorLayout layout;
    layout.name = "map";
    for (size_t i = 0; i < map->size(); ++i) {  // map items are sensors 0, 1, … in order
      auto b = binding_on((*map)[i].segment, static_cast<uint16_t>(i), skeleton);
      if (!b) return fail(b.error().code, "vrpn map: " + b.error().message);
      layout.bindings.push_back(std::move(*b));
    }
    return layout;
  }
  return solver::standard_layout(param(spec, "layout", "6"), skeleton);
}

Result<std::unique_ptr<devices::SensorSource>> open_vrpn_source(const devices::SourceSpec& spec,
                                                                std::shared_ptr<const Clock> clock) {
  auto address = net::parse_vrpn_address(spec.target);
  if (!address) return tl::unexpected(address.error());
  auto axes = parse_axes(param(spec, "axes", "x,y,z"));
  if (!axes) return tl::unexpected(axes.error());
  float scale_m = 1;
  if (auto it = spec.params.find("scale"); it != spec.params.end()) {
    char* end = nullptr;
    scale_m = std::strtof(it->second.c_str(), &end);
    if (*end != '\0' || !(scale_m > 0) || !std::isfinite(scale_m))
      return fail(Errc::invalid_argument, "vrpn scale: '" + it->second + "' is not a positive number");
  }
  auto stale_ms = parse_int(param(spec, "stale_ms", "250"), 10, 60000, "vrpn stale_ms");
  if (!stale_ms) return tl::unexpected(stale_ms.error());
  // Which VRPN device and sensor feeds which mount: the explicit map in its order; or the layout
  // in order, over the main device's sensors, or over the devices (main, then devices=) when
  // there are several, each device's sensor 0.
  net::VrpnTrackerRemote::Options o;
  o.tracker = *address;
  auto device_index = [&](const std::string& name) {
    if (name.empty() || name == o.tracker.device) return 0;
    for (size_t i = 0; i < o.more_trackers.size(); ++i)
      if (o.more_trackers[i] == name) return int(i + 1);
    o.more_trackers.push_back(name);
    return int(o.more_trackers.size());
  };
  for (const std::string& name : split_list(param(spec, "devices", ""))) device_index(name);
  std::vector<std::array<int, 3>> wiring;  // device, sensor, mount id
  if (auto it = spec.params.find("map"); it != spec.params.end()) {
    auto m = parse_map(it->second);
    if (!m) return tl::unexpected(m.error());
    for (size_t i = 0; i < m->size(); ++i) wiring.push_back({device_index((*m)[i].device), (*m)[i].sensor, int(i)});
  } else {
    const std::string layout = param(spec, "layout", "6");
    const int count = layout == "3" ? 3 : layout == "6" ? 6 : layout == "11" ? 11 : int(kMaxSensors);
    const bool per_device = !o.more_trackers.empty();
    for (int i = 0; i < (per_device ? int(o.more_trackers.size()) + 1 : count); ++i)
      wiring.push_back({per_device ? i : 0, per_device ? 0 : i, i});
  }
  SensorMap map((o.more_trackers.size() + 1) * kMaxSensors, -1);
  for (const auto& [device, sensor, id] : wiring) map[size_t(device) * kMaxSensors + size_t(sensor)] = id;
  o.button_device = param(spec, "buttons", "");
  if (!clock) clock = std::make_shared<SteadyClock>();
  auto remote = net::VrpnTrackerRemote::create(o, clock);
  if (!remote) return tl::unexpected(remote.error());
  std::string description = "vrpn:" + address->text() + " (VRPN tracker";
  if (!o.more_trackers.empty()) description += " + " + std::to_string(o.more_trackers.size()) + " more devices";
  if (!o.button_device.empty()) description += ", buttons " + o.button_device;
  description += ")";
  return std::unique_ptr<devices::SensorSource>(new VrpnSource(std::move(*remote), std::move(clock), std::move(map),
                                                               *axes, scale_m, *stale_ms / 1000.0,
                                                               std::move(description)));
}

}  // namespace mimic::service
