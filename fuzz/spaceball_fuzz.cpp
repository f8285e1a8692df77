// libFuzzer entry point for the Spaceball serial codec: any byte stream frames into packets no
// longer than the framer's buffer, decodes without crashing, and a D packet re-encodes to the
// same values; any body survives escaping and framing unchanged.
#include <array>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <span>
#include <vector>

#include "mimic/devices/spaceball_packet.h"

namespace sb = mimic::devices::spaceball;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  sb::Framer f;
  for (std::size_t i = 0; i < size; ++i) {
    if (!f.push(data[i])) continue;
    const auto p = f.packet();
    if (p.empty() || p.size() > sb::Framer::kMaxPacket) std::abort();
    const sb::Packet d = sb::decode(p);
    if (d.kind == sb::PacketKind::displacement) {
      const auto body = sb::displacement_body(d.period_16th_ms, d.axes);
      if (!std::equal(body.begin(), body.end(), p.begin(), p.end())) std::abort();
    }
  }
  // Escaping round trip of the input itself as a packet body.
  if (size > 0 && size <= sb::Framer::kMaxPacket && data[0] != 0x0A) {
    std::vector<std::uint8_t> wire(2 * size + 1);
    const std::size_t n = sb::encode_packet({data, size}, wire);
    if (n == 0) std::abort();
    sb::Framer g;
    std::size_t packets = 0;
    for (std::size_t i = 0; i < n; ++i) {
      if (g.push(wire[i])) {
        ++packets;
        if (!std::equal(g.packet().begin(), g.packet().end(), data, data + size)) std::abort();
      }
    }
    if (packets != 1) std::abort();
  }
  return 0;
}
