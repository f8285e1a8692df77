// 3Dconnexion USB SpaceMouse / SpaceNavigator through hidapi, as an InputSource.
//
// make_hid_spacemouse_source opens the given hidraw path, or the first device whose
// vendor/product id is in hid::models(); a missing or unplugged device is status
// "disconnected" and is looked for again every reconnect_interval_s. Reports go through
// HidReportSource, the same decoder and mapping a simulator or a replay feeds directly.
#pragma once

#include <cstdint>
#include <memory>
#include <mutex>
#include <span>
#include <string>
#include <vector>

#include "mimic/core/result.h"
#include "mimic/devices/hid_packet.h"
#include "mimic/devices/source.h"

namespace mimic::devices {

// An InputSource fed with raw HID reports (report ID in byte 0). feed() may run on any thread;
// poll() never waits for it (try-lock).
class HidReportSource : public InputSource {
 public:
  explicit HidReportSource(std::string description, hid::Scaling scaling = {});

  // Applies one report; returns the hid::ReportChange mask.
  uint32_t feed(std::span<const uint8_t> report, double host_time_s);
  void set_state(DeviceState state, std::string last_error = {});
  void set_description(std::string description);
  void count_reconnect();

  Status start() override;
  bool poll(InputFrame& out) override;
  DeviceStatus status() const override;
  void stop() override;

 private:
  hid::Scaling scaling_;
  hid::Decoder decoder_;  // feed() side only
  std::mutex frame_mutex_;
  InputFrame frame_{};
  bool fresh_ = false;
  mutable std::mutex status_mutex_;
  DeviceStatus status_;
};

struct HidSpaceMouseOptions {
  std::string path;         // hidraw path as hidapi lists it; empty: first known device
  uint16_t vendor_id = 0;   // with path empty: only this vendor (0 = any known)
  uint16_t product_id = 0;  // with path empty: only this product (0 = any known)
  hid::Scaling scaling;
  double reconnect_interval_s = 1.0;
};

// Errc::unsupported when this build has no hidapi.
Result<std::unique_ptr<InputSource>> make_hid_spacemouse_source(HidSpaceMouseOptions options);

struct HidDeviceInfo {
  std::string path;
  uint16_t vendor_id = 0;
  uint16_t product_id = 0;
  std::string manufacturer;
  std::string product;
  std::string serial;
  const hid::Model* model = nullptr;  // nullptr: not a known 6-DOF device
};

// Every HID device hidapi sees (known 6-DOF devices have `model` set). Errc::unsupported
// without hidapi; Errc::io_error when hidapi cannot start.
Result<std::vector<HidDeviceInfo>> list_hid_devices();

}  // namespace mimic::devices
