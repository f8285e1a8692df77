#include "serial_input_driver.h"

#include "mimic/core/clock.h"

#include <array>
#include <chrono>
#include <exception>

namespace mimic::devices::detail {

SerialInputDriver::SerialInputDriver(std::string scheme, std::string path, LineSettings line, SerialTiming timing)
    : scheme_(std::move(scheme)), path_(std::move(path)), line_settings_(line), timing_(timing) {}

SerialInputDriver::~SerialInputDriver() { shutdown(); }

Status SerialInputDriver::start() {
  if (running_.load()) return {};
  if (path_.empty()) return fail(Errc::invalid_argument, scheme_ + ": no device path given");
  running_.store(true);
  {
    std::lock_guard lock(status_mutex_);
    state_ = DeviceState::connecting;
  }
  thread_ = std::thread([this] { run(); });
  return {};
}

void SerialInputDriver::stop() { shutdown(); }

void SerialInputDriver::shutdown() {
  running_.store(false);
  if (thread_.joinable()) thread_.join();
  line_.close();
  open_ = false;
  std::lock_guard lock(status_mutex_);
  state_ = DeviceState::disconnected;
}

bool SerialInputDriver::poll(InputFrame& out) {
  // try_lock: if the I/O thread is mid-update the frame is simply picked up on the next poll.
  std::unique_lock lock(frame_mutex_, std::try_to_lock);
  if (!lock.owns_lock() || !frame_fresh_) return false;
  out = frame_;
  frame_fresh_ = false;
  return true;
}

DeviceStatus SerialInputDriver::status() const {
  DeviceStatus s;
  std::lock_guard lock(status_mutex_);
  s.state = state_;
  s.description = scheme_ + ":" + path_;
  if (!identity_.empty()) s.description += " " + identity_;
  s.last_error = last_error_;
  s.records = records_.load();
  s.resyncs = resyncs_.load();
  s.reconnects = reconnects_.load();
  return s;
}

void SerialInputDriver::write(std::string_view bytes) {
  if (!open_) return;
  auto r = line_.write({reinterpret_cast<const uint8_t*>(bytes.data()), bytes.size()});
  if (!r) set_last_error(r.error().what());
}

void SerialInputDriver::publish(const InputFrame& frame) {
  std::lock_guard lock(frame_mutex_);
  frame_ = frame;
  frame_fresh_ = true;
}

void SerialInputDriver::set_ready() {
  std::lock_guard lock(status_mutex_);
  state_ = DeviceState::streaming;
}

void SerialInputDriver::set_identity(std::string text) {
  std::lock_guard lock(status_mutex_);
  identity_ = std::move(text);
}

void SerialInputDriver::set_last_error(std::string text) {
  std::lock_guard lock(status_mutex_);
  last_error_ = std::move(text);
}

void SerialInputDriver::close_line(const char* why) {
  line_.close();
  open_ = false;
  set_last_error(std::string(why));
  std::lock_guard lock(status_mutex_);
  state_ = DeviceState::disconnected;
}

void SerialInputDriver::run() {
  std::array<uint8_t, 256> buf{};
  while (running_.load()) {
    try {
      const double now = steady_now_s();
      if (!open_) {
        if (now < next_open_s_) {
          std::this_thread::sleep_for(std::chrono::milliseconds(20));
          continue;
        }
        next_open_s_ = now + timing_.reconnect_interval_s;
        auto r = line_.open(path_, line_settings_);
        if (!r) {
          set_last_error(r.error().what());
          std::lock_guard lock(status_mutex_);
          state_ = DeviceState::disconnected;
          continue;
        }
        open_ = true;
        if (ever_opened_) reconnects_.fetch_add(1);
        ever_opened_ = true;
        last_rx_s_ = now;
        last_probe_s_ = now;
        {
          std::lock_guard lock(status_mutex_);
          state_ = DeviceState::connecting;
        }
        on_open(now);
        continue;
      }
      auto n = line_.read(buf, 20);
      const double t = steady_now_s();
      if (!n) {
        close_line(n.error().what().c_str());
        continue;
      }
      if (*n > 0) {
        last_rx_s_ = t;
        {
          std::lock_guard lock(status_mutex_);
          if (state_ == DeviceState::stale) state_ = DeviceState::streaming;
        }
        on_bytes({buf.data(), *n}, t);
      }
      on_tick(t);
      const double silent = t - last_rx_s_;
      if (silent > timing_.dead_after_s) {
        // Probes went unanswered: the device is off or unplugged. Reopening also resets a
        // USB-serial adapter that wedged, and the start-up runs again.
        close_line("device stopped answering");
        next_open_s_ = t;
        continue;
      }
      if (silent > timing_.probe_after_s && t - last_probe_s_ > timing_.probe_after_s) {
        last_probe_s_ = t;
        {
          std::lock_guard lock(status_mutex_);
          if (state_ == DeviceState::streaming) state_ = DeviceState::stale;
        }
        send_probe();
      }
    } catch (const std::exception& e) {
      // Nothing here is expected to throw; if it does the thread carries on and says why.
      set_last_error(std::string("internal error: ") + e.what());
      std::this_thread::sleep_for(std::chrono::milliseconds(100));
    }
  }
}

}  // namespace mimic::devices::detail
