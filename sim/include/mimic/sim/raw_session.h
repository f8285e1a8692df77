// A device session kept byte for byte, and played back to the real driver.
//
// RawByteRecorder is the ByteTap `mimic record --raw` gives a serial driver: it collects what
// the driver read and wrote (from the driver's thread) and hands it to the log writer (from the
// recording loop's), as raw records between the samples.
//
// RecordedSerialDevice plays a log's raw records back as a serial device (served on a pty by
// PtyServer): each chunk the device sent goes out once the host has written everything it had
// written before that chunk in the recording, at the same delay after it. The driver thus sees
// the session as it happened — start-up answers, then the stream — and `mimic replay
// --through-driver` checks that it decodes the same samples.
#pragma once

#include <cstdint>
#include <mutex>
#include <span>
#include <vector>

#include "mimic/core/result.h"
#include "mimic/devices/serial.h"
#include "mimic/sim/log.h"
#include "mimic/sim/serial_device.h"

namespace mimic::sim {

class RawByteRecorder final : public devices::ByteTap {
 public:
  void on_bytes(bool from_device, std::span<const uint8_t> bytes, double host_time_s) override;
  // Appends what arrived since the last call as raw records. Returns the number of chunks.
  Result<size_t> write_to(LogWriter& writer);
  uint64_t bytes_seen() const;

 private:
  mutable std::mutex mutex_;
  std::vector<RawChunk> pending_;
  uint64_t bytes_ = 0;
};

class RecordedSerialDevice final : public SerialDevice {
 public:
  // `chunks` in log order; `baud` paces the output like the real line (0: unthrottled).
  RecordedSerialDevice(std::vector<RawChunk> chunks, unsigned baud);

  void host_opened(double now_s) override;
  void receive(std::span<const uint8_t> bytes, double now_s) override;
  void advance(double now_s) override;

  uint64_t bytes_to_send() const { return from_device_bytes_; }

 private:
  struct Step {
    double recorded_s = 0;
    uint64_t host_bytes_before = 0;   // bytes the host had written before this chunk
    double host_written_s = 0;        // when, in the recording, it had written the last of them
    const RawChunk* chunk = nullptr;  // a from-device chunk
  };
  std::vector<RawChunk> chunks_;
  std::vector<Step> steps_;
  uint64_t from_device_bytes_ = 0;
  size_t next_ = 0;
  uint64_t host_bytes_ = 0;
  double opened_s_ = 0, first_recorded_s_ = 0;
  // When (replay time) the host's byte count first reached each step's requirement.
  double reached_s_ = -1;
  uint64_t reached_for_ = UINT64_MAX;
};

}  // namespace mimic::sim
