// A serial port for the device drivers: open by path, raw 8N1 (or 8N2), no flow control, reads
// with a timeout. Boost.Asio runs underneath and stays out of this header.
//
// One thread uses a port at a time (the driver's reader thread). Modem-control ioctls (RTS,
// which resets a Flock of Birds) fail with ENOTTY on a pseudo-terminal; set_rts() reports that
// as "not available" instead of an error so drivers run unchanged against simulators.
#pragma once

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <span>
#include <string>

#include "mimic/core/result.h"

namespace mimic::devices {

// Sees every byte a port reads or writes, stamped on the host's steady clock (seconds) as the
// call returns: `mimic record --raw` keeps them so a session can be replayed through the driver.
// Called on the thread that uses the port; an implementation hands the bytes over itself.
class ByteTap {
 public:
  virtual ~ByteTap() = default;
  virtual void on_bytes(bool from_device, std::span<const uint8_t> bytes, double host_time_s) = 0;
};

struct SerialOptions {
  int baud = 115200;
  int stop_bits = 1;     // 1 or 2
  bool xonxoff = false;  // software flow control (Spaceball); never for a Flock
  bool rtscts = false;   // hardware handshake (Magellan)
};

class SerialPort {
 public:
  // Opens `path` and sets the line. Errc::not_found when the path does not exist,
  // Errc::io_error when it cannot be opened or configured.
  static Result<std::unique_ptr<SerialPort>> open(const std::string& path, const SerialOptions& options);
  ~SerialPort();
  SerialPort(const SerialPort&) = delete;
  SerialPort& operator=(const SerialPort&) = delete;

  const std::string& path() const;

  // Reads whatever arrives first (at least one byte), waiting at most `timeout`; returns 0 on
  // timeout. Errc::disconnected when the device went away (EOF, EIO, hang-up).
  Result<size_t> read_some(std::span<uint8_t> out, std::chrono::microseconds timeout);
  // Reads exactly out.size() bytes within `timeout` overall; Errc::timeout with the count
  // received so far otherwise.
  Status read_exact(std::span<uint8_t> out, std::chrono::microseconds timeout);
  Status write(std::span<const uint8_t> bytes);
  // Drops bytes received but not read yet (kernel buffer).
  void flush_input();

  // Asserts (true) or drops (false) RTS. Returns false when the line has no modem control
  // (a pseudo-terminal, some USB adapters); errors other than that are Errc::io_error.
  Result<bool> set_rts(bool asserted);
  Result<bool> set_dtr(bool asserted);
  // Every byte read or written from now on goes to `tap` too (nullptr: none).
  void set_tap(std::shared_ptr<ByteTap> tap);

 private:
  struct Impl;
  explicit SerialPort(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace mimic::devices
