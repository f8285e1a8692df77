// The serial port as the 6-DOF drivers use it, over devices::SerialPort (Boost.Asio): open with
// line settings and raise DTR/RTS where the line has them, read with a timeout, write, close.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <span>
#include <string>

#include "mimic/core/result.h"
#include "mimic/devices/serial.h"

namespace mimic::devices::detail {

struct LineSettings {
  unsigned baud = 9600;
  unsigned stop_bits = 1;
  bool rts_cts = false;  // hardware handshake (Magellan)
};

class SerialLine {
 public:
  Status open(const std::string& path, const LineSettings& settings);
  bool is_open() const { return port_ != nullptr; }
  // Waits up to timeout_ms for bytes; 0 bytes on timeout; Errc::disconnected when the device
  // went away.
  Result<size_t> read(std::span<uint8_t> out, int timeout_ms);
  Status write(std::span<const uint8_t> bytes);
  void close() { port_.reset(); }

 private:
  std::unique_ptr<SerialPort> port_;
};

}  // namespace mimic::devices::detail
