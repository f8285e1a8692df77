// A pseudo-terminal pair for virtual serial devices: the simulator owns the master side, a
// driver (ours or any other program) opens slave_path() like a serial port.
//
// Linux specifics the simulators rely on: the termios settings are shared by both sides, so the
// master can read the baud and framing the driver chose; modem-control ioctls fail with ENOTTY
// (a simulator cannot see RTS); a read on the master fails with EIO while no slave fd is open,
// which is how a simulator sees the host open or close the port.
#pragma once

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <span>
#include <string>

#include "mimic/core/result.h"

namespace mimic::sim {

// What the driver configured on the slave side.
struct LineSettings {
  int baud = 0;  // 0 when the speed is not a standard rate
  int data_bits = 8;
  bool parity = false;
  int stop_bits = 1;
  bool rtscts = false;  // hardware flow control
  bool ixon = false;    // software flow control on output
  bool raw = true;      // no canonical mode, echo or output processing
};

class Pty {
 public:
  // Opens a new master (non-blocking, raw, 8N1) and unlocks its slave.
  static Result<Pty> open();

  Pty() = default;
  Pty(Pty&& other) noexcept;
  Pty& operator=(Pty&& other) noexcept;
  Pty(const Pty&) = delete;
  Pty& operator=(const Pty&) = delete;
  ~Pty();

  int master_fd() const { return fd_; }
  const std::string& slave_path() const { return slave_path_; }

  enum class Wait { readable, timeout, no_peer };
  // Waits until the master has bytes to read or the timeout passes. no_peer (returned at once)
  // means no process has the slave open.
  Wait wait_readable(std::chrono::microseconds timeout) const;
  // Non-blocking read; 0 when nothing is pending. Errc::disconnected when no slave is open.
  Result<size_t> read(std::span<uint8_t> out);
  // Writes what fits without blocking and returns the count (the rest is lost while the host
  // does not read). Errc::disconnected when no slave is open: the bytes are lost, as on a cable
  // with nobody listening.
  Result<size_t> write(std::span<const uint8_t> bytes);
  // Discards bytes the driver wrote that were not read yet.
  void flush_input();

  LineSettings line_settings() const;

 private:
  void close();
  int fd_ = -1;
  std::string slave_path_;
};

}  // namespace mimic::sim
