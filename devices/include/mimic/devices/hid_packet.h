// 3Dconnexion USB HID reports (as hidapi returns them: report ID in byte 0): the model table by
// vendor/product id, a decoder that accumulates reports 1 (translation, or all six axes in the
// 13-byte form), 2 (rotation), 3 (buttons) and 17h (battery) into device state, and encoders
// for the simulator and tests. Pure code, no allocation. Reference: docs/device-protocols.md §4.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>

#include "mimic/devices/sample.h"

namespace mimic::devices::hid {

constexpr uint16_t kVendorLogitech = 0x046D;
constexpr uint16_t kVendor3Dconnexion = 0x256F;

struct Model {
  uint16_t vendor_id;
  uint16_t product_id;
  const char* name;
  uint8_t buttons;     // as VRPN counts them; 0 when unknown
  bool combined_axes;  // sends one 13-byte report 1 instead of reports 1 + 2
};

// All known 6-DOF devices (§4.1). CadMouse, keyboards and numpads are not in it.
std::span<const Model> models() noexcept;
// nullptr when the ids are not a known 6-DOF device.
const Model* find_model(uint16_t vendor_id, uint16_t product_id) noexcept;

using Axes = std::array<int16_t, 6>;  // raw HID order: X, Y, Z, RX, RY, RZ

enum ReportChange : uint32_t {
  kChangedNone = 0,
  kChangedTranslation = 1u << 0,
  kChangedRotation = 1u << 1,
  kChangedButtons = 1u << 2,
  kChangedBattery = 1u << 3,
  kUnknownReport = 1u << 4,  // unknown ID or too short: ignored, state untouched
};

// Device state built from reports. Parse by report ID, never by length: read lengths differ by
// OS and model.
class Decoder {
 public:
  // Applies one report; returns a mask of ReportChange bits.
  uint32_t feed(std::span<const uint8_t> report) noexcept;

  const Axes& axes() const noexcept { return axes_; }
  uint32_t buttons() const noexcept { return buttons_; }     // bit n = button n+1 (report 3 bit n)
  int battery_percent() const noexcept { return battery_; }  // -1 until a 17h report
  uint64_t unknown_reports() const noexcept { return unknown_; }

 private:
  Axes axes_{};
  uint32_t buttons_ = 0;
  int battery_ = -1;
  uint64_t unknown_ = 0;
};

// --- Encoding (simulator, tests) ---
std::array<uint8_t, 7> translation_report(const Axes& a) noexcept;  // 01 X Y Z
std::array<uint8_t, 7> rotation_report(const Axes& a) noexcept;     // 02 RX RY RZ
std::array<uint8_t, 13> combined_report(const Axes& a) noexcept;    // 01 X Y Z RX RY RZ
// 03 + button bytes, LSB first; `button_count` rounds up to whole bytes (at least one).
size_t button_report(uint32_t buttons, unsigned button_count, std::span<uint8_t, 5> out) noexcept;

// --- Values ---
struct Scaling {
  float full_scale = 350.0f;  // logical range ±350 (descriptor); VRPN uses 400, pyspacemouse 350
  int null_radius = 0;
};

// Raw HID → InputFrame (+X right, +Y up, +Z toward the user). Raw +Y points toward the user and
// raw +Z presses down (inferred from spacenavd and pyspacemouse), so the frame is
// (X, −Z, Y, RX, −RZ, RY).
void to_frame(const Axes& raw, const Scaling& s, InputFrame& out) noexcept;
Axes from_frame(const InputFrame& in, const Scaling& s) noexcept;

}  // namespace mimic::devices::hid
