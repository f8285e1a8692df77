// A virtual Ascension Flock of Birds on a pseudo-terminal. It speaks the real RS-232 protocol
// byte for byte (device-protocols.md §1): the command state machine with RS232-TO-FBB prefixes,
// EXAMINE/CHANGE parameters with their exact sizes, auto-configuration with a busy window,
// group mode, all seven record formats with button and group bytes, point and stream modes,
// report rates, hemispheres, sleep/run, and error codes. Output is paced like the real line: a
// record leaves the pty when its last byte would have left the UART at the configured baud, and
// stream cycles follow the measurement rate, on the simulator's own monotonic clock.
//
// Any driver can open slave_path(), ours or another program's. A pty has no RTS line, so the
// reset a driver would do with RTS is a test hook (reset()), as are silence, garbage, torn
// records and phase errors. Seeded: the same seed and the same commands give the same bytes.
#pragma once

#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <span>
#include <string>

#include "mimic/core/result.h"
#include "mimic/devices/sample.h"

namespace mimic::sim {

// Fills `out` with the pose of sensor `bird` (0-based, in FBB address order) at simulation time
// t_s: position in metres and reference_from_sensor orientation in Mimic's axes, the reference
// being the transmitter (see flock_packet.h for how that maps to the Flock's own frame).
// `out.sensor` already holds the bird's FBB address. Called on the simulator's thread, once per
// record it sends.
using FlockSampleProvider = std::function<void(double t_s, int bird, devices::SensorSample& out)>;

// The built-in provider: sensors on the pelvis, head, wrists, ankles, elbows and knees of the
// default skeleton, every DOF swinging on its own sinusoid; the transmitter stands 0.5 m behind
// the pelvis at 1 m height, facing the body's forward (+Z), so every sensor stays in the forward
// hemisphere.
FlockSampleProvider make_builtin_flock_motion(uint64_t seed);

struct VirtualFlockConfig {
  int birds = 1;            // sensors; with 1 and no ERC the unit is standalone (address 0)
  bool erc = false;         // an extended range controller at address 1 (144 in scale), sensors after
  int baud = 115200;        // the DIP-switch baud; output is paced at it
  bool pace_output = true;  // false: write records as soon as they are measured
  double measurement_rate_hz = 103.3;
  double crystal_mhz = 25.0;
  uint16_t software_revision = 0x4303;  // 3.67
  double auto_config_busy_s = 0.35;     // commands arriving this long after P 50 N are dropped
  double reply_delay_s = 0.0002;        // firmware latency before a reply starts
  double first_reply_delay_s = 0;       // the first EXAMINE answer, if later than that
  uint64_t seed = 1;
  // Random faults per record sent (seeded): probability that a record loses a byte, gains a
  // stray byte, or is cut short. 0 = a clean line.
  double fault_rate = 0.0;
  // Garbage and one partial record at power-up and after reset(), as real units send.
  bool boot_garbage = true;
  FlockSampleProvider provider;  // empty: make_builtin_flock_motion(seed)
  // SCHED_FIFO priority (1-99) for the serving thread, for timing measurements on a loaded
  // machine; 0 = normal scheduling. Silently normal without CAP_SYS_NICE.
  int realtime_priority = 0;
  // Called on the simulator thread right after a record's bytes were written to the pty, with
  // the host monotonic time (seconds, steady_clock) and the bird's address. For latency tests.
  std::function<void(double host_time_s, int address, std::span<const uint8_t> record)> on_record_written;
  // Called on the simulator thread with every chunk of bytes that crossed the line: to_host =
  // true for what the unit sent (as written to the pty), false for what it received. For byte
  // logs; host monotonic time in seconds.
  std::function<void(double host_time_s, bool to_host, std::span<const uint8_t> bytes)> on_bytes;
};

struct VirtualFlockStats {
  uint64_t records_sent = 0;
  // Records whose position lay beyond the range's full scale on some axis: the words pinned at
  // the limit, as a real unit's do. A sensor too far from its transmitter.
  uint64_t saturated_records = 0;
  // Records whose position lay outside the selected hemisphere and went out mirrored through
  // the transmitter (the Flock cannot tell the two apart).
  uint64_t mirrored_records = 0;
  uint64_t commands = 0;
  uint64_t invalid_commands = 0;    // set error 6
  uint64_t dropped_while_busy = 0;  // bytes ignored during auto-configuration
  uint64_t faults_injected = 0;
  uint64_t host_opens = 0;       // times a process opened the slave
  uint64_t line_mismatches = 0;  // the host's termios did not match the unit's baud/8N1
  bool streaming = false;
  bool group_mode = false;
  bool configured = false;  // FBB auto-configuration done (or standalone)
  bool sleeping = false;
};

class VirtualFlock {
 public:
  static Result<std::unique_ptr<VirtualFlock>> create(VirtualFlockConfig config);
  ~VirtualFlock();
  VirtualFlock(const VirtualFlock&) = delete;
  VirtualFlock& operator=(const VirtualFlock&) = delete;

  const std::string& slave_path() const;
  // Starts serving on a thread of its own. Fails if already started.
  Status start();
  void stop();

  // Test hooks, safe from any thread.
  // Power-cycle as an RTS pulse would: stream stops, parameters go back to defaults, the flock
  // needs auto-configuration again; then boot garbage.
  void reset();
  // The unit neither answers nor sends for `duration` (a pulled cable), then resumes where it was.
  void go_silent(std::chrono::milliseconds duration);
  void inject_garbage(size_t bytes);  // random bytes, most with bit 7 clear, between records
  void tear_next_record();            // the next record loses its second half
  void phase_error_next_record();     // the next record gets bit 7 set on a middle byte
  void drop_byte_next_record();       // one byte of the next record vanishes

  VirtualFlockStats stats() const;

 private:
  struct Impl;
  explicit VirtualFlock(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace mimic::sim
