#include "mimic/devices/hid_spacemouse.h"

#include <array>
#include <atomic>
#include <chrono>
#include <cwchar>
#include <thread>

#include "mimic/core/clock.h"

#ifdef MIMIC_WITH_HIDAPI
#include <hidapi/hidapi.h>
#endif

namespace mimic::devices {

HidReportSource::HidReportSource(std::string description, hid::Scaling scaling) : scaling_(scaling) {
  status_.description = std::move(description);
}

uint32_t HidReportSource::feed(std::span<const uint8_t> report, double host_time_s) {
  const uint32_t changes = decoder_.feed(report);
  {
    std::lock_guard lock(status_mutex_);
    if (changes & hid::kUnknownReport) {
      ++status_.resyncs;
    } else {
      ++status_.records;
      status_.state = DeviceState::streaming;
    }
  }
  if (changes & (hid::kChangedTranslation | hid::kChangedRotation | hid::kChangedButtons)) {
    InputFrame f;
    hid::to_frame(decoder_.axes(), scaling_, f);
    f.buttons = decoder_.buttons();
    f.host_time_s = host_time_s;
    std::lock_guard lock(frame_mutex_);
    frame_ = f;
    fresh_ = true;
  }
  return changes;
}

void HidReportSource::set_state(DeviceState state, std::string last_error) {
  std::lock_guard lock(status_mutex_);
  status_.state = state;
  if (!last_error.empty()) status_.last_error = std::move(last_error);
}

void HidReportSource::set_description(std::string description) {
  std::lock_guard lock(status_mutex_);
  status_.description = std::move(description);
}

void HidReportSource::count_reconnect() {
  std::lock_guard lock(status_mutex_);
  ++status_.reconnects;
}

Status HidReportSource::start() {
  set_state(DeviceState::connecting);
  return {};
}

bool HidReportSource::poll(InputFrame& out) {
  std::unique_lock lock(frame_mutex_, std::try_to_lock);
  if (!lock.owns_lock() || !fresh_) return false;
  out = frame_;
  fresh_ = false;
  return true;
}

DeviceStatus HidReportSource::status() const {
  std::lock_guard lock(status_mutex_);
  return status_;
}

void HidReportSource::stop() { set_state(DeviceState::disconnected); }

#ifdef MIMIC_WITH_HIDAPI

namespace {

std::string narrow(const wchar_t* w) {
  std::string s;
  if (!w) return s;
  for (; *w; ++w) s.push_back(*w < 128 ? static_cast<char>(*w) : '?');
  return s;
}

// hid_init/hid_exit are process-wide; keep hidapi initialised once for the program's life.
bool hidapi_ready() {
  static const bool ok = hid_init() == 0;
  return ok;
}

class HidSpaceMouse final : public InputSource {
 public:
  explicit HidSpaceMouse(HidSpaceMouseOptions o)
      : opt_(std::move(o)),
        core_("spacemouse:" + (opt_.path.empty() ? std::string("(first found)") : opt_.path), opt_.scaling) {}
  ~HidSpaceMouse() override { stop(); }

  Status start() override {
    if (running_.exchange(true)) return {};
    core_.set_state(DeviceState::connecting);
    thread_ = std::thread([this] { run(); });
    return {};
  }
  bool poll(InputFrame& out) override { return core_.poll(out); }
  DeviceStatus status() const override { return core_.status(); }
  void stop() override {
    running_.store(false);
    if (thread_.joinable()) thread_.join();
    core_.stop();
  }

 private:
  hid_device* open_device() {
    if (!hidapi_ready()) {
      core_.set_state(DeviceState::error, "hidapi could not start");
      return nullptr;
    }
    std::string path = opt_.path;
    const hid::Model* model = nullptr;
    if (path.empty()) {
      hid_device_info* all = hid_enumerate(0, 0);
      for (auto* d = all; d; d = d->next) {
        if (opt_.vendor_id && d->vendor_id != opt_.vendor_id) continue;
        if (opt_.product_id && d->product_id != opt_.product_id) continue;
        if ((model = hid::find_model(d->vendor_id, d->product_id))) {
          path = d->path;
          break;
        }
      }
      hid_free_enumeration(all);
      if (path.empty()) {
        core_.set_state(DeviceState::disconnected, "no 3Dconnexion device found");
        return nullptr;
      }
    }
    hid_device* dev = hid_open_path(path.c_str());
    if (!dev) {
      core_.set_state(DeviceState::disconnected, "cannot open " + path + " (permissions?)");
      return nullptr;
    }
    std::string desc = "spacemouse:" + path;
    if (model) desc += std::string(" ") + model->name;
    core_.set_description(desc);
    return dev;
  }

  void run() {
    std::array<uint8_t, 64> buf{};
    bool opened_before = false;
    while (running_.load()) {
      hid_device* dev = open_device();
      if (!dev) {
        const auto until = std::chrono::steady_clock::now() + std::chrono::duration<double>(opt_.reconnect_interval_s);
        while (running_.load() && std::chrono::steady_clock::now() < until) {
          std::this_thread::sleep_for(std::chrono::milliseconds(20));
        }
        continue;
      }
      if (opened_before) core_.count_reconnect();
      opened_before = true;
      core_.set_state(DeviceState::streaming);
      while (running_.load()) {
        const int n = hid_read_timeout(dev, buf.data(), buf.size(), 50);
        if (n < 0) {
          core_.set_state(DeviceState::disconnected, "device unplugged: " + narrow(hid_error(dev)));
          break;
        }
        if (n > 0) core_.feed({buf.data(), static_cast<size_t>(n)}, steady_now_s());
      }
      hid_close(dev);
    }
  }

  HidSpaceMouseOptions opt_;
  HidReportSource core_;
  std::thread thread_;
  std::atomic<bool> running_{false};
};

}  // namespace

Result<std::unique_ptr<InputSource>> make_hid_spacemouse_source(HidSpaceMouseOptions options) {
  return std::unique_ptr<InputSource>(std::make_unique<HidSpaceMouse>(std::move(options)));
}

Result<std::vector<HidDeviceInfo>> list_hid_devices() {
  if (!hidapi_ready()) return fail(Errc::io_error, "hidapi could not start");
  std::vector<HidDeviceInfo> out;
  hid_device_info* all = hid_enumerate(0, 0);
  for (auto* d = all; d; d = d->next) {
    HidDeviceInfo i;
    i.path = d->path ? d->path : "";
    i.vendor_id = d->vendor_id;
    i.product_id = d->product_id;
    i.manufacturer = narrow(d->manufacturer_string);
    i.product = narrow(d->product_string);
    i.serial = narrow(d->serial_number);
    i.model = hid::find_model(d->vendor_id, d->product_id);
    out.push_back(std::move(i));
  }
  hid_free_enumeration(all);
  return out;
}

#else

Result<std::unique_ptr<InputSource>> make_hid_spacemouse_source(HidSpaceMouseOptions) {
  return fail(Errc::unsupported, "this build has no hidapi (MIMIC_WITH_HIDAPI=OFF)");
}

Result<std::vector<HidDeviceInfo>> list_hid_devices() {
  return fail(Errc::unsupported, "this build has no hidapi (MIMIC_WITH_HIDAPI=OFF)");
}

#endif

}  // namespace mimic::devices
