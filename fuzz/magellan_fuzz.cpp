// libFuzzer entry point for the Magellan serial codec: framing and decoding never crash, a d or
// k packet that decodes re-encodes to the very same characters, and every nibble character the
// decoder accepted has even parity.
#include <array>
#include <cstddef>
#include <cstdint>
#include <cstdlib>

#include "mimic/devices/magellan_packet.h"

namespace mg = mimic::devices::magellan;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  mg::Framer f;
  for (std::size_t i = 0; i < size; ++i) {
    if (!f.push(data[i])) continue;
    const auto p = f.packet();
    if (p.empty() || p.size() > mg::Framer::kMaxPacket) std::abort();
    const mg::Packet d = mg::decode(p);
    if (d.kind == mg::PacketKind::data) {
      const auto again = mg::data_packet(d.axes);
      if (!std::equal(p.begin(), p.end(), again.begin())) std::abort();
      for (std::size_t k = 1; k < p.size(); ++k) {
        if (__builtin_popcount(p[k]) % 2 != 0) std::abort();
      }
    }
    if (d.kind == mg::PacketKind::keys) {
      std::array<std::uint8_t, 6> k{};
      const std::size_t n = mg::keys_packet(d.buttons, k);
      // A 4-nibble k packet whose extra nibble is 0 re-encodes in the 3-nibble form.
      if (n - 1 != p.size() && !(p.size() == 5 && p[4] == '0')) std::abort();
      if (!std::equal(k.begin(), k.begin() + 4, p.begin())) std::abort();
    }
  }
  return 0;
}
