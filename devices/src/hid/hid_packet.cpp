#include "mimic/devices/hid_packet.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>

namespace mimic::devices::hid {

namespace {

constexpr Model kModels[] = {
    {kVendorLogitech, 0xC603, "SpaceMouse Plus XT USB", 11, false},
    {kVendorLogitech, 0xC605, "CadMan", 0, false},
    {kVendorLogitech, 0xC606, "SpaceMouse Classic", 0, false},
    {kVendorLogitech, 0xC621, "Spaceball 5000 USB", 12, false},
    {kVendorLogitech, 0xC623, "SpaceTraveler", 8, false},
    {kVendorLogitech, 0xC625, "SpacePilot", 21, false},
    {kVendorLogitech, 0xC626, "SpaceNavigator", 2, false},
    {kVendorLogitech, 0xC627, "SpaceExplorer", 15, false},
    {kVendorLogitech, 0xC628, "SpaceNavigator for Notebooks", 2, false},
    {kVendorLogitech, 0xC629, "SpacePilot Pro", 31, false},
    {kVendorLogitech, 0xC62B, "SpaceMouse Pro", 27, false},
    {kVendor3Dconnexion, 0xC62E, "SpaceMouse Wireless (cable)", 2, true},
    {kVendor3Dconnexion, 0xC62F, "SpaceMouse Wireless (receiver)", 2, true},
    {kVendor3Dconnexion, 0xC631, "SpaceMouse Pro Wireless (cable)", 32, true},
    {kVendor3Dconnexion, 0xC632, "SpaceMouse Pro Wireless (receiver)", 32, true},
    {kVendor3Dconnexion, 0xC633, "SpaceMouse Enterprise", 0, true},
    {kVendor3Dconnexion, 0xC635, "SpaceMouse Compact", 2, true},
    {kVendor3Dconnexion, 0xC636, "SpaceMouse Module", 0, true},
    {kVendor3Dconnexion, 0xC638, "SpaceMouse Pro Wireless BT", 0, true},
    {kVendor3Dconnexion, 0xC63A, "SpaceMouse Wireless BT", 0, true},
    {kVendor3Dconnexion, 0xC652, "3Dconnexion Universal Receiver", 0, true},
};

int16_t le16(const uint8_t* p) { return static_cast<int16_t>(p[0] | (p[1] << 8)); }

void put_le16(uint8_t* p, int16_t v) {
  const auto u = static_cast<uint16_t>(v);
  p[0] = static_cast<uint8_t>(u & 0xFF);
  p[1] = static_cast<uint8_t>(u >> 8);
}

float scale(int16_t raw, const Scaling& s) {
  if (std::abs(static_cast<int>(raw)) <= s.null_radius) return 0.0f;
  return std::clamp(static_cast<float>(raw) / s.full_scale, -1.0f, 1.0f);
}

int16_t clamp16(float v) { return static_cast<int16_t>(std::clamp(std::round(v), -32768.0f, 32767.0f)); }

}  // namespace

std::span<const Model> models() noexcept { return kModels; }

const Model* find_model(uint16_t vid, uint16_t pid) noexcept {
  for (const auto& m : kModels) {
    if (m.vendor_id == vid && m.product_id == pid) return &m;
  }
  return nullptr;
}

uint32_t Decoder::feed(std::span<const uint8_t> r) noexcept {
  if (r.empty()) {
    ++unknown_;
    return kUnknownReport;
  }
  auto set = [&](size_t first_axis, size_t count, const uint8_t* data) {
    bool changed = false;
    for (size_t i = 0; i < count; ++i) {
      const int16_t v = le16(data + 2 * i);
      changed |= axes_[first_axis + i] != v;
      axes_[first_axis + i] = v;
    }
    return changed;
  };
  switch (r[0]) {
    case 1: {
      if (r.size() >= 13) {
        uint32_t c = 0;
        if (set(0, 3, &r[1])) c |= kChangedTranslation;
        if (set(3, 3, &r[7])) c |= kChangedRotation;
        return c;
      }
      if (r.size() >= 7) return set(0, 3, &r[1]) ? kChangedTranslation : kChangedNone;
      break;
    }
    case 2:
      if (r.size() >= 7) return set(3, 3, &r[1]) ? kChangedRotation : kChangedNone;
      break;
    case 3: {
      if (r.size() < 2) break;
      uint32_t b = 0;
      for (size_t i = 1; i < r.size() && i <= 4; ++i) b |= static_cast<uint32_t>(r[i]) << (8 * (i - 1));
      const bool changed = b != buttons_;
      buttons_ = b;
      return changed ? kChangedButtons : kChangedNone;
    }
    case 0x17:
      if (r.size() < 2) break;
      battery_ = std::min<int>(r[1], 100);
      return kChangedBattery;
    default: break;
  }
  ++unknown_;
  return kUnknownReport;
}

std::array<uint8_t, 7> translation_report(const Axes& a) noexcept {
  std::array<uint8_t, 7> r{1};
  for (size_t i = 0; i < 3; ++i) put_le16(&r[1 + 2 * i], a[i]);
  return r;
}

std::array<uint8_t, 7> rotation_report(const Axes& a) noexcept {
  std::array<uint8_t, 7> r{2};
  for (size_t i = 0; i < 3; ++i) put_le16(&r[1 + 2 * i], a[3 + i]);
  return r;
}

std::array<uint8_t, 13> combined_report(const Axes& a) noexcept {
  std::array<uint8_t, 13> r{1};
  for (size_t i = 0; i < 6; ++i) put_le16(&r[1 + 2 * i], a[i]);
  return r;
}

size_t button_report(uint32_t buttons, unsigned button_count, std::span<uint8_t, 5> out) noexcept {
  const size_t bytes = std::clamp<size_t>((button_count + 7) / 8, 1, 4);
  out[0] = 3;
  for (size_t i = 0; i < bytes; ++i) out[1 + i] = static_cast<uint8_t>(buttons >> (8 * i));
  return 1 + bytes;
}

void to_frame(const Axes& raw, const Scaling& s, InputFrame& out) noexcept {
  out.translation = {scale(raw[0], s), -scale(raw[2], s), scale(raw[1], s)};
  out.rotation = {scale(raw[3], s), -scale(raw[5], s), scale(raw[4], s)};
}

Axes from_frame(const InputFrame& in, const Scaling& s) noexcept {
  const float f = s.full_scale;
  return {clamp16(in.translation.x * f), clamp16(in.translation.z * f), clamp16(-in.translation.y * f),
          clamp16(in.rotation.x * f),    clamp16(in.rotation.z * f),    clamp16(-in.rotation.y * f)};
}

}  // namespace mimic::devices::hid
