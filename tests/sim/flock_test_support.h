// Shared by the virtual Flock and Flock driver tests: a raw host end on a pty slave, static
// sensor poses, fast timings.
#pragma once

#include <fcntl.h>
#include <poll.h>
#include <termios.h>
#include <unistd.h>

#include <chrono>
#include <string>
#include <thread>
#include <vector>

#include <glm/glm.hpp>
#include <glm/gtc/quaternion.hpp>

#include "mimic/devices/flock.h"
#include "mimic/sim/virtual_flock.h"

namespace mimic::test {

// The host end of a serial line, opened the plain POSIX way (what any other program would do).
class RawHost {
 public:
  explicit RawHost(const std::string& path, speed_t speed = B115200) {
    fd_ = ::open(path.c_str(), O_RDWR | O_NOCTTY | O_CLOEXEC);
    if (fd_ < 0) return;
    termios t{};
    ::tcgetattr(fd_, &t);
    ::cfmakeraw(&t);
    t.c_cflag |= CLOCAL | CREAD;
    ::cfsetspeed(&t, speed);
    ::tcsetattr(fd_, TCSANOW, &t);
  }
  ~RawHost() {
    if (fd_ >= 0) ::close(fd_);
  }
  bool ok() const { return fd_ >= 0; }
  void send(const std::vector<uint8_t>& bytes) { [[maybe_unused]] auto n = ::write(fd_, bytes.data(), bytes.size()); }
  // Reads until `n` bytes arrived or `timeout` passed.
  std::vector<uint8_t> read(size_t n, std::chrono::milliseconds timeout = std::chrono::milliseconds(500)) {
    std::vector<uint8_t> out;
    const auto until = std::chrono::steady_clock::now() + timeout;
    while (out.size() < n) {
      const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(until - std::chrono::steady_clock::now());
      if (left.count() <= 0) break;
      pollfd p{fd_, POLLIN, 0};
      if (::poll(&p, 1, static_cast<int>(left.count())) <= 0) break;
      uint8_t b[256];
      const ssize_t got = ::read(fd_, b, std::min(sizeof b, n - out.size()));
      if (got <= 0) break;
      out.insert(out.end(), b, b + got);
    }
    return out;
  }
  // Everything that arrives within `window`.
  std::vector<uint8_t> drain(std::chrono::milliseconds window) { return read(1 << 20, window); }

 private:
  int fd_ = -1;
};

// Bird i (0-based) holds still at a distinct pose inside the forward hemisphere and the 36 in
// range; buttons 0x10 on odd birds.
inline devices::SensorSample static_pose(int bird) {
  devices::SensorSample s;
  s.position_m = glm::vec3(0.05f * static_cast<float>(bird) - 0.1f, 0.2f - 0.03f * static_cast<float>(bird),
                           0.3f + 0.04f * static_cast<float>(bird));
  s.orientation = glm::normalize(glm::angleAxis(
      0.3f + 0.2f * static_cast<float>(bird), glm::normalize(glm::vec3(1.0f, 2.0f, 0.5f + static_cast<float>(bird)))));
  s.buttons = (bird % 2) ? 0x10u : 0u;
  return s;
}

inline sim::FlockSampleProvider static_provider(float scale = 1.0f) {
  return [scale](double, int bird, devices::SensorSample& out) {
    const devices::SensorSample s = static_pose(bird);
    out.position_m = s.position_m * scale;
    out.orientation = s.orientation;
    out.buttons = s.buttons;
  };
}

inline sim::VirtualFlockConfig fast_sim(int birds) {
  sim::VirtualFlockConfig c;
  c.birds = birds;
  c.auto_config_busy_s = 0.05;
  c.provider = static_provider();
  return c;
}

inline devices::FlockConfig fast_driver(const std::string& path, int birds) {
  devices::FlockConfig c;
  c.path = path;
  c.birds = birds;
  c.reply_timeout = std::chrono::milliseconds(300);
  c.settle = std::chrono::milliseconds(20);
  c.auto_config_wait = std::chrono::milliseconds(80);
  c.stale_after = std::chrono::milliseconds(150);
  c.reinit_after = std::chrono::milliseconds(350);
  c.retry_every = std::chrono::milliseconds(50);
  return c;
}

// Polls `src` until `want` samples arrived or `timeout` passed.
inline std::vector<devices::SensorSample> collect(devices::SensorSource& src, size_t want,
                                                  std::chrono::milliseconds timeout = std::chrono::milliseconds(3000)) {
  std::vector<devices::SensorSample> got;
  std::vector<devices::SensorSample> buf(64);
  const auto until = std::chrono::steady_clock::now() + timeout;
  while (got.size() < want && std::chrono::steady_clock::now() < until) {
    const size_t n = src.poll(buf);
    got.insert(got.end(), buf.begin(), buf.begin() + static_cast<long>(n));
    if (n == 0) std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  return got;
}

}  // namespace mimic::test
