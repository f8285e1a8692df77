// A simulated serial device as a pure state machine on a clock the caller owns, and the thread
// that serves one on a pseudo-terminal. The protocol engines (virtual Spaceball, Magellan)
// derive from SerialDevice; tests can drive an engine byte by byte without any pty.
#pragma once

#include <atomic>
#include <cstdint>
#include <cstdio>
#include <deque>
#include <functional>
#include <memory>
#include <mutex>
#include <span>
#include <string>
#include <string_view>
#include <thread>

#include "mimic/core/result.h"
#include "mimic/sim/pty.h"

namespace mimic::sim {

class SerialDevice {
 public:
  // bits_per_byte: 10 for 8N1, 11 for 8N2. baud 0 sends without throttling.
  SerialDevice(unsigned baud, unsigned bits_per_byte);
  virtual ~SerialDevice() = default;

  // The host opened the port (the pty master stopped reporting "no peer"): real devices are
  // switched on with the computer, so the simulators treat it as power-up.
  virtual void host_opened(double now_s) = 0;
  virtual void host_closed(double now_s);
  // Bytes the host wrote.
  virtual void receive(std::span<const uint8_t> bytes, double now_s) = 0;
  // Emits whatever is due by now_s (data packets, delayed replies) into the output queue.
  virtual void advance(double now_s) = 0;

  // Moves bytes whose transmission has completed by now_s (at the line's baud rate) into `out`.
  size_t take_output(double now_s, std::span<uint8_t> out);
  // Earliest time more output may become available; a large value when none is queued.
  double next_output_s() const;

  // The line the real device runs. PtyServer compares the host's termios with it when the host
  // first writes after opening the port, and counts and logs a mismatch: a real device would
  // read garbage or lose bytes, a pty carries them regardless.
  struct ExpectedLine {
    int baud = 9600;
    int min_stop_bits = 1;
    int max_stop_bits = 2;
    bool rtscts = false;
  };
  const ExpectedLine& expected_line() const { return expected_line_; }

  // A switched-off device: input is ignored and nothing is sent until unmuted.
  void set_muted(bool muted) { muted_ = muted; }
  bool muted() const { return muted_; }

 protected:
  // Queues bytes to go out no earlier than at_s.
  void send(std::span<const uint8_t> bytes, double at_s);
  void send(std::string_view text, double at_s);
  void drop_output();
  void expect_line(ExpectedLine line) { expected_line_ = line; }

 private:
  struct Chunk {
    double at_s;
    std::string bytes;
  };
  std::deque<Chunk> queue_;
  double byte_s_;
  double line_free_s_ = 0;
  bool muted_ = false;
  ExpectedLine expected_line_;
};

struct PtyServeStats {
  uint64_t bytes_in = 0;
  uint64_t bytes_out = 0;
  uint64_t host_opens = 0;
  uint64_t line_mismatches = 0;  // host line settings that differ from the device's
};

// Serves a SerialDevice on a new pty from its own thread. Time t = 0 is the moment start()
// returns. Optional byte log: one line per chunk, "<t_s> <in|out> <hex bytes>".
class PtyServer {
 public:
  static Result<std::unique_ptr<PtyServer>> start(std::unique_ptr<SerialDevice> device,
                                                  const std::string& log_path = {});
  ~PtyServer();
  PtyServer(const PtyServer&) = delete;
  PtyServer& operator=(const PtyServer&) = delete;

  const std::string& path() const { return pty_.slave_path(); }
  void set_muted(bool muted);
  PtyServeStats stats() const;
  LineSettings line_settings() const { return pty_.line_settings(); }
  void stop();

 private:
  PtyServer(Pty pty, std::unique_ptr<SerialDevice> device, std::FILE* log);
  void run();
  double now_s() const;
  void log(const char* dir, std::span<const uint8_t> bytes, double t);
  void check_line(double t);

  Pty pty_;
  std::unique_ptr<SerialDevice> device_;
  std::FILE* log_ = nullptr;
  std::thread thread_;
  std::atomic<bool> running_{true};
  mutable std::mutex mutex_;  // guards device_ and stats_ against set_muted()/stats()
  PtyServeStats stats_;
  double t0_ = 0;
};

}  // namespace mimic::sim
