#include "mimic/sim/serial_device.h"

#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cstring>
#include <limits>

#include "mimic/core/clock.h"

namespace mimic::sim {

SerialDevice::SerialDevice(unsigned baud, unsigned bits_per_byte)
    : byte_s_(baud == 0 ? 0.0 : static_cast<double>(bits_per_byte) / baud) {}

void SerialDevice::host_closed(double) { drop_output(); }

void SerialDevice::send(std::span<const uint8_t> bytes, double at_s) {
  if (muted_ || bytes.empty()) return;
  queue_.push_back({at_s, std::string(reinterpret_cast<const char*>(bytes.data()), bytes.size())});
}

void SerialDevice::send(std::string_view text, double at_s) {
  send(std::span<const uint8_t>(reinterpret_cast<const uint8_t*>(text.data()), text.size()), at_s);
}

void SerialDevice::drop_output() {
  queue_.clear();
  line_free_s_ = 0;
}

size_t SerialDevice::take_output(double now_s, std::span<uint8_t> out) {
  if (muted_) {
    queue_.clear();
    return 0;
  }
  size_t n = 0;
  while (!queue_.empty() && n < out.size()) {
    Chunk& c = queue_.front();
    if (c.at_s > now_s) break;
    // The line sends one byte per byte_s_; a byte is out once its last bit is.
    line_free_s_ = std::max(line_free_s_, c.at_s);
    size_t i = 0;
    while (i < c.bytes.size() && n < out.size() && line_free_s_ + byte_s_ <= now_s) {
      out[n++] = static_cast<uint8_t>(c.bytes[i++]);
      line_free_s_ += byte_s_;
    }
    c.bytes.erase(0, i);
    if (!c.bytes.empty()) {
      c.at_s = line_free_s_;
      break;
    }
    queue_.pop_front();
  }
  return n;
}

double SerialDevice::next_output_s() const {
  if (queue_.empty()) return std::numeric_limits<double>::max();
  return std::max(queue_.front().at_s, line_free_s_) + byte_s_;
}

// --- PtyServer ---

Result<std::unique_ptr<PtyServer>> PtyServer::start(std::unique_ptr<SerialDevice> device, const std::string& log_path) {
  auto pty = Pty::open();
  if (!pty) return tl::unexpected(pty.error());
  std::FILE* log = nullptr;
  if (!log_path.empty()) {
    log = std::fopen(log_path.c_str(), "w");
    if (!log) return fail(Errc::io_error, log_path + ": " + std::strerror(errno));
  }
  // A master whose slave was never opened reports neither data nor hang-up, so the first open
  // would be invisible. Opening and closing the slave once puts the master into the hang-up
  // state, and the driver's open becomes the power-up edge.
  if (const int fd = ::open(pty->slave_path().c_str(), O_RDWR | O_NOCTTY | O_CLOEXEC); fd >= 0) ::close(fd);
  std::unique_ptr<PtyServer> s(new PtyServer(std::move(*pty), std::move(device), log));
  s->thread_ = std::thread([p = s.get()] { p->run(); });
  return s;
}

PtyServer::PtyServer(Pty pty, std::unique_ptr<SerialDevice> device, std::FILE* log)
    : pty_(std::move(pty)), device_(std::move(device)), log_(log), t0_(steady_now_s()) {}

PtyServer::~PtyServer() { stop(); }

void PtyServer::stop() {
  running_.store(false);
  if (thread_.joinable()) thread_.join();
  if (log_) {
    std::fclose(log_);
    log_ = nullptr;
  }
}

double PtyServer::now_s() const { return steady_now_s() - t0_; }

void PtyServer::set_muted(bool muted) {
  std::lock_guard lock(mutex_);
  device_->set_muted(muted);
}

PtyServeStats PtyServer::stats() const {
  std::lock_guard lock(mutex_);
  return stats_;
}

void PtyServer::log(const char* dir, std::span<const uint8_t> bytes, double t) {
  if (!log_ || bytes.empty()) return;
  std::fprintf(log_, "%.6f %s", t, dir);
  for (uint8_t b : bytes) std::fprintf(log_, " %02x", b);
  std::fputc('\n', log_);
  std::fflush(log_);
}

void PtyServer::check_line(double t) {
  const LineSettings got = pty_.line_settings();
  const auto& want = device_->expected_line();
  const bool ok = got.baud == want.baud && got.data_bits == 8 && !got.parity && got.stop_bits >= want.min_stop_bits &&
                  got.stop_bits <= want.max_stop_bits && got.rtscts == want.rtscts;
  if (ok) return;
  ++stats_.line_mismatches;
  if (log_) {
    std::fprintf(log_, "%.6f line %d %d%c%d%s, device runs %d 8N%d%s\n", t, got.baud, got.data_bits,
                 got.parity ? 'P' : 'N', got.stop_bits, got.rtscts ? " rtscts" : "", want.baud, want.min_stop_bits,
                 want.rtscts ? " rtscts" : "");
    std::fflush(log_);
  }
}

void PtyServer::run() {
  std::array<uint8_t, 512> buf{};
  bool host_present = false;
  bool line_checked = false;
  while (running_.load()) {
    double t = now_s();
    double wait_s;
    {
      std::lock_guard lock(mutex_);
      wait_s = std::clamp(device_->next_output_s() - t, 0.0002, 0.005);
    }
    const auto w = pty_.wait_readable(std::chrono::microseconds(static_cast<long>(wait_s * 1e6)));
    t = now_s();
    if (w == Pty::Wait::no_peer) {
      {
        std::lock_guard lock(mutex_);
        if (host_present) device_->host_closed(t);
      }
      host_present = false;
      // Nobody has the port open; the master would report "no peer" in a tight loop.
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
      continue;
    }
    std::lock_guard lock(mutex_);
    if (!host_present) {
      host_present = true;
      line_checked = false;
      ++stats_.host_opens;
      device_->host_opened(t);
    }
    if (w == Pty::Wait::readable) {
      auto n = pty_.read(buf);
      if (n && *n > 0) {
        if (!line_checked) {
          line_checked = true;
          check_line(t);
        }
        stats_.bytes_in += *n;
        log("in", {buf.data(), *n}, t);
        device_->receive({buf.data(), *n}, t);
      }
    }
    device_->advance(t);
    const size_t out = device_->take_output(t, buf);
    if (out > 0) {
      auto r = pty_.write({buf.data(), out});
      if (r) {
        stats_.bytes_out += *r;
        log("out", {buf.data(), *r}, t);
      }
    }
  }
}

}  // namespace mimic::sim
