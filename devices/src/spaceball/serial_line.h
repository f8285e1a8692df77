// The serial port as the 6-DOF drivers use it: open with line settings, read with a timeout,
// write everything, close. Modem-line requests that a pseudo-terminal rejects are ignored.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <string>

#include "mimic/core/result.h"

namespace mimic::devices::detail {

struct LineSettings {
  unsigned baud = 9600;
  unsigned stop_bits = 1;
  bool rts_cts = false;  // hardware handshake (Magellan)
};

class SerialLine {
 public:
  SerialLine() = default;
  SerialLine(const SerialLine&) = delete;
  SerialLine& operator=(const SerialLine&) = delete;
  ~SerialLine() { close(); }

  Status open(const std::string& path, const LineSettings& settings);
  bool is_open() const { return fd_ >= 0; }
  // Waits up to timeout_ms for bytes; 0 bytes on timeout; an error when the device went away.
  Result<size_t> read(std::span<uint8_t> out, int timeout_ms);
  Status write(std::span<const uint8_t> bytes);
  void close();

 private:
  int fd_ = -1;
};

}  // namespace mimic::devices::detail
