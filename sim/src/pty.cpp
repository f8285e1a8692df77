#include "mimic/sim/pty.h"

#include <fcntl.h>
#include <poll.h>
#include <termios.h>
#include <unistd.h>

#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <utility>

namespace mimic::sim {

namespace {

std::string errno_text(const char* what) { return std::string(what) + ": " + std::strerror(errno); }

int baud_of(speed_t s) {
  switch (s) {
    case B2400: return 2400;
    case B4800: return 4800;
    case B9600: return 9600;
    case B19200: return 19200;
    case B38400: return 38400;
    case B57600: return 57600;
    case B115200: return 115200;
    case B230400: return 230400;
    default: return 0;
  }
}

}  // namespace

Result<Pty> Pty::open() {
  Pty p;
  p.fd_ = ::posix_openpt(O_RDWR | O_NOCTTY | O_NONBLOCK | O_CLOEXEC);
  if (p.fd_ < 0) return fail(Errc::io_error, errno_text("posix_openpt"));
  if (::grantpt(p.fd_) != 0) return fail(Errc::io_error, errno_text("grantpt"));
  if (::unlockpt(p.fd_) != 0) return fail(Errc::io_error, errno_text("unlockpt"));
  char name[128];
  if (::ptsname_r(p.fd_, name, sizeof name) != 0) return fail(Errc::io_error, errno_text("ptsname"));
  p.slave_path_ = name;
  // Raw 8N1 until the driver sets its own line: records carry 11h/13h and CR bytes.
  termios t{};
  if (::tcgetattr(p.fd_, &t) == 0) {
    ::cfmakeraw(&t);
    t.c_cflag |= CLOCAL | CREAD;
    ::cfsetspeed(&t, B115200);
    ::tcsetattr(p.fd_, TCSANOW, &t);
  }
  return p;
}

Pty::Pty(Pty&& other) noexcept : fd_(std::exchange(other.fd_, -1)), slave_path_(std::move(other.slave_path_)) {}

Pty& Pty::operator=(Pty&& other) noexcept {
  if (this != &other) {
    close();
    fd_ = std::exchange(other.fd_, -1);
    slave_path_ = std::move(other.slave_path_);
  }
  return *this;
}

Pty::~Pty() { close(); }

void Pty::close() {
  if (fd_ >= 0) ::close(fd_);
  fd_ = -1;
}

Pty::Wait Pty::wait_readable(std::chrono::microseconds timeout) const {
  pollfd pfd{fd_, POLLIN, 0};
  // ppoll for sub-millisecond timeouts: record timing at 115200 baud is tens of microseconds.
  timespec ts{static_cast<time_t>(timeout.count() / 1000000), static_cast<long>((timeout.count() % 1000000) * 1000)};
  const int n = ::ppoll(&pfd, 1, &ts, nullptr);
  if (n <= 0) return Wait::timeout;
  if (pfd.revents & POLLIN) return Wait::readable;
  if (pfd.revents & (POLLHUP | POLLERR)) return Wait::no_peer;
  return Wait::timeout;
}

Result<size_t> Pty::read(std::span<uint8_t> out) {
  const ssize_t n = ::read(fd_, out.data(), out.size());
  if (n >= 0) return static_cast<size_t>(n);
  if (errno == EAGAIN || errno == EINTR) return size_t{0};
  if (errno == EIO) return fail(Errc::disconnected, "no process has " + slave_path_ + " open");
  return fail(Errc::io_error, errno_text("pty read"));
}

Result<size_t> Pty::write(std::span<const uint8_t> bytes) {
  size_t done = 0;
  while (done < bytes.size()) {
    const ssize_t n = ::write(fd_, bytes.data() + done, bytes.size() - done);
    if (n > 0) {
      done += static_cast<size_t>(n);
      continue;
    }
    if (n < 0 && errno == EINTR) continue;
    if (n < 0 && errno == EIO) return fail(Errc::disconnected, "no process has " + slave_path_ + " open");
    // Buffer full: the host is not reading. The rest is lost, as on a real line whose receiver
    // overruns; the simulator must never stall on a slow host.
    if (n < 0 && errno == EAGAIN) return done;
    return fail(Errc::io_error, errno_text("pty write"));
  }
  return done;
}

void Pty::flush_input() { ::tcflush(fd_, TCIFLUSH); }

LineSettings Pty::line_settings() const {
  LineSettings s;
  termios t{};
  if (::tcgetattr(fd_, &t) != 0) return s;
  s.baud = baud_of(::cfgetospeed(&t));
  switch (t.c_cflag & CSIZE) {
    case CS5: s.data_bits = 5; break;
    case CS6: s.data_bits = 6; break;
    case CS7: s.data_bits = 7; break;
    default: s.data_bits = 8; break;
  }
  s.parity = (t.c_cflag & PARENB) != 0;
  s.stop_bits = (t.c_cflag & CSTOPB) ? 2 : 1;
  s.rtscts = (t.c_cflag & CRTSCTS) != 0;
  s.ixon = (t.c_iflag & IXON) != 0;
  s.raw = !(t.c_lflag & (ICANON | ECHO)) && !(t.c_oflag & OPOST);
  return s;
}

}  // namespace mimic::sim
