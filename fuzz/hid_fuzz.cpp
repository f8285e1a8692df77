// libFuzzer entry point for the 3Dconnexion HID report decoder. The input is a sequence of
// reports, each prefixed by its length byte (as hidapi hands them over, ID first). Decoding
// never crashes, unknown reports leave the state alone, and axis reports round-trip.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <span>

#include "mimic/devices/hid_packet.h"

namespace hid = mimic::devices::hid;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  hid::Decoder d;
  std::size_t i = 0;
  while (i < size) {
    const std::size_t len = std::min<std::size_t>(data[i], size - i - 1);
    const std::span<const std::uint8_t> r(data + i + 1, len);
    i += 1 + len;
    const auto before_axes = d.axes();
    const auto before_buttons = d.buttons();
    const std::uint32_t c = d.feed(r);
    if (c & hid::kUnknownReport) {
      if (d.axes() != before_axes || d.buttons() != before_buttons) std::abort();
      continue;
    }
    if (!r.empty() && r[0] == 1 && r.size() >= 13) {
      const auto again = hid::combined_report(d.axes());
      if (!std::equal(again.begin(), again.end(), r.begin())) std::abort();
    }
    if (!r.empty() && r[0] == 2 && r.size() >= 7) {
      const auto again = hid::rotation_report(d.axes());
      if (!std::equal(again.begin(), again.end(), r.begin())) std::abort();
    }
    mimic::devices::InputFrame f;
    hid::to_frame(d.axes(), {}, f);
    for (int k = 0; k < 3; ++k) {
      if (!(f.translation[k] >= -1.0f && f.translation[k] <= 1.0f)) std::abort();
      if (!(f.rotation[k] >= -1.0f && f.rotation[k] <= 1.0f)) std::abort();
    }
  }
  return 0;
}
