// Shared machinery of the serial 6-DOF drivers (Spaceball, Magellan): an I/O thread that opens
// the port, runs the protocol's start-up, reads bytes into the protocol's decoder, probes a
// silent device and reopens the port when it stays silent. poll() only copies the latest frame
// out under a try-lock, so the realtime loop never waits for the I/O thread.
#pragma once

#include <atomic>
#include <cstdint>
#include <mutex>
#include <span>
#include <string>
#include <string_view>
#include <thread>

#include "mimic/devices/source.h"
#include "serial_line.h"

namespace mimic::devices::detail {

struct SerialTiming {
  double probe_after_s = 1.0;         // silence before the protocol's probe is sent
  double dead_after_s = 3.0;          // silence before the port is closed and reopened
  double reconnect_interval_s = 0.5;  // between attempts to open the port
};

class SerialInputDriver : public InputSource {
 public:
  SerialInputDriver(std::string scheme, std::string path, LineSettings line, SerialTiming timing);
  ~SerialInputDriver() override;

  Status start() override;
  bool poll(InputFrame& out) override;
  DeviceStatus status() const override;
  void stop() override;

 protected:
  // Hooks run on the I/O thread only.
  virtual void on_open(double now_s) = 0;
  virtual void on_bytes(std::span<const uint8_t> bytes, double now_s) = 0;
  virtual void on_tick(double now_s) = 0;
  virtual void send_probe() = 0;

  // Helpers for the hooks.
  void write(std::string_view bytes);
  void publish(const InputFrame& frame);
  void set_ready();                     // start-up finished: data may flow
  void set_identity(std::string text);  // appended to the status description
  void set_last_error(std::string text);
  void count_record() { records_.fetch_add(1, std::memory_order_relaxed); }
  void count_resync(uint64_t n = 1) { resyncs_.fetch_add(n, std::memory_order_relaxed); }
  const std::string& path() const { return path_; }

  // Joins the I/O thread; derived destructors call it before their members go away.
  void shutdown();

 private:
  void run();
  void close_line(const char* why);

  const std::string scheme_;
  const std::string path_;
  const LineSettings line_settings_;
  const SerialTiming timing_;

  SerialLine line_;
  std::thread thread_;
  std::atomic<bool> running_{false};

  // Latest frame, handed from the I/O thread to poll().
  std::mutex frame_mutex_;
  InputFrame frame_{};
  bool frame_fresh_ = false;

  mutable std::mutex status_mutex_;
  DeviceState state_ = DeviceState::disconnected;
  std::string identity_;
  std::string last_error_;
  std::atomic<uint64_t> records_{0};
  std::atomic<uint64_t> resyncs_{0};
  std::atomic<uint64_t> reconnects_{0};

  // I/O-thread state.
  bool open_ = false;
  bool ever_opened_ = false;
  double last_rx_s_ = 0;
  double last_probe_s_ = 0;
  double next_open_s_ = 0;
};

}  // namespace mimic::devices::detail
