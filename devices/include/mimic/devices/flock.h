// Ascension Flock of Birds driver over a serial port: a standalone bird or a flock on the Fast
// Bird Bus (FBB addressing, group mode, auto-configuration), stream or point mode, any of the
// seven record formats, hemisphere, measurement and report rate, standard or extended range.
//
// A reader thread owns the port. It runs the start-up sequence, timestamps every record at its
// last byte on the host monotonic clock (steady_clock, seconds) and hands samples to the
// realtime side through a bounded lock-free queue; poll() never blocks, allocates or throws.
// When the device falls silent (unplugged, powered off, reset) the status goes stale, then
// disconnected, and the thread re-runs the start-up sequence until the device answers again.
//
// Samples: sensor = the bird's place in address order (0 for the first bird, at address 1, or 2
// behind an ERC), as the sensor layouts number sensors; position in metres and
// reference_from_sensor in Mimic's axes, the reference being the transmitter (flock_packet.h).
#pragma once

#include <chrono>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "mimic/core/result.h"
#include "mimic/devices/flock_packet.h"
#include "mimic/devices/serial.h"
#include "mimic/devices/source.h"

namespace mimic::devices {

struct FlockConfig {
  std::string path;  // serial device, e.g. /dev/ttyUSB0
  int baud = 115200;
  int birds = 1;     // sensors; 1 without an ERC = standalone (no FBB addressing)
  bool erc = false;  // extended range controller at address 1 (144 in scale)
  flock::Format format = flock::Format::position_quaternion;
  bool button = false;  // append the button byte (BUTTON MODE 1)
  bool stream = true;   // false: point mode, one 'B' per cycle at point_rate_hz
  double point_rate_hz = 100.0;
  bool group = true;  // group mode for a multi-bird flock (stream mode needs it)
  flock::Hemisphere hemisphere = flock::Hemisphere::forward;
  double measurement_rate_hz = 0;  // 0 keeps the device's rate; else 14–144 Hz
  int report_every = 1;            // 1, 2, 8 or 32 (Q/R/S/T)
  bool range_72in = false;         // standard transmitter at 72 in full scale (half resolution)

  // Timing. The defaults follow the real hardware; tests against the simulator shorten them.
  std::chrono::milliseconds reply_timeout{500};     // EXAMINE answers
  std::chrono::milliseconds settle{100};            // after 'B' before flushing stale output
  std::chrono::milliseconds auto_config_wait{700};  // after P 50 N (the unit is deaf meanwhile)
  std::chrono::milliseconds reset_hold{1000};       // RTS asserted (real lines only)
  std::chrono::milliseconds reset_settle{2000};     // after RTS drops
  std::chrono::milliseconds stale_after{250};       // no record this long: status stale
  std::chrono::milliseconds reinit_after{1000};     // no record this long: start-up again
  std::chrono::milliseconds retry_every{500};       // between failed start-up attempts
  size_t queue_capacity = 1024;                     // samples between reader and poll()
  // SCHED_FIFO priority (1-99) for the reader thread, so records are stamped and handed over
  // promptly on a loaded machine; 0 leaves the normal scheduler. Needs CAP_SYS_NICE; without it
  // the thread runs normally and info().realtime says so. The thread blocks in reads, so it
  // never starves the machine.
  int realtime_priority = 0;
  // Sees every byte exchanged with the device (serial.h), e.g. to record a session raw.
  std::shared_ptr<ByteTap> tap;
};

// From a "flock:<path>?birds=4&baud=115200&format=pos_quat&mode=stream&hemisphere=forward&
// rate=103.3&report=1&range=36&erc=0&button=0&group=1&timeout_ms=250" spec.
Result<FlockConfig> flock_config_from_spec(const SourceSpec& spec);

// What the start-up sequence learned from the device.
struct FlockInfo {
  std::string model;              // parameter 15, trimmed: "6DFOB", "6DERC" ...
  std::string software_revision;  // "3.67"
  double crystal_mhz = 0;
  double measurement_rate_hz = 0;
  std::vector<int> sensor_addresses;  // FBB address of sensor i
  std::vector<uint8_t> flock_status;  // parameter 36, one byte per address 1..14 (empty standalone)
  bool realtime = false;              // the reader thread got its SCHED_FIFO priority
};

// One answer to an error-code query (parameters 10/16 of the master).
struct FlockError {
  int code = 0;
  int extra = 0;     // for code 13, the FBB address that did not answer
  std::string text;  // error_name(code)
};

class FlockSource final : public SensorSource {
 public:
  explicit FlockSource(FlockConfig config);
  ~FlockSource() override;

  // Opens the port and runs the start-up sequence once, then starts the reader thread.
  // Errc::not_found / io_error for the port, Errc::timeout when the device does not answer,
  // Errc::io_error with the bird's address when a unit does not come up.
  Status start() override;
  size_t poll(std::span<SensorSample> out) override;
  DeviceStatus status() const override;
  void stop() override;

  FlockInfo info() const;
  // Queries while running. Each stops output, sends EXAMINE to the master (address −1) or to an
  // FBB address, reads the reply and resumes the stream. Not for the realtime loop: they wait for
  // the reader thread, at most `timeout`. Errc::timeout when the unit does not answer.
  Result<std::vector<uint8_t>> examine(uint8_t parameter, int address = -1,
                                       std::chrono::milliseconds timeout = std::chrono::milliseconds(2000));
  Result<FlockError> query_error(std::chrono::milliseconds timeout = std::chrono::milliseconds(2000));
  Result<flock::BirdStatus> query_status(int address = -1,
                                         std::chrono::milliseconds timeout = std::chrono::milliseconds(2000));
  // Samples dropped because poll() did not keep up with the queue.
  uint64_t dropped_samples() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace mimic::devices
