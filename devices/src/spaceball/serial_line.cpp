#include "serial_line.h"

#include <chrono>

namespace mimic::devices::detail {

Status SerialLine::open(const std::string& path, const LineSettings& s) {
  close();
  SerialOptions o;
  o.baud = static_cast<int>(s.baud);
  o.stop_bits = static_cast<int>(s.stop_bits);
  // XON/XOFF stay off in the kernel: the Spaceball framer drops them itself, and an escaped
  // packet never carries a raw 11h/13h.
  o.xonxoff = false;
  o.rtscts = s.rts_cts;
  auto port = SerialPort::open(path, o);
  if (!port) return tl::unexpected(port.error());
  // spacenavd raises DTR and RTS. A pseudo-terminal has no modem lines; that is not an error.
  (void)(*port)->set_dtr(true);
  if (!s.rts_cts) (void)(*port)->set_rts(true);
  (*port)->flush_input();
  port_ = std::move(*port);
  return {};
}

Result<size_t> SerialLine::read(std::span<uint8_t> out, int timeout_ms) {
  if (!port_) return fail(Errc::disconnected, "port is closed");
  return port_->read_some(out, std::chrono::milliseconds(timeout_ms));
}

Status SerialLine::write(std::span<const uint8_t> bytes) {
  if (!port_) return fail(Errc::disconnected, "port is closed");
  return port_->write(bytes);
}

}  // namespace mimic::devices::detail
