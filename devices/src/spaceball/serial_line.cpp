#include "serial_line.h"

#include <fcntl.h>
#include <poll.h>
#include <sys/ioctl.h>
#include <termios.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

namespace mimic::devices::detail {

namespace {

speed_t speed_for(unsigned baud) {
  switch (baud) {
    case 1200: return B1200;
    case 2400: return B2400;
    case 4800: return B4800;
    case 9600: return B9600;
    case 19200: return B19200;
    case 38400: return B38400;
    case 57600: return B57600;
    case 115200: return B115200;
    default: return B0;
  }
}

std::string errno_text(const std::string& what) { return what + ": " + std::strerror(errno); }

}  // namespace

Status SerialLine::open(const std::string& path, const LineSettings& s) {
  close();
  const speed_t speed = speed_for(s.baud);
  if (speed == B0) return fail(Errc::invalid_argument, "unsupported baud rate " + std::to_string(s.baud));
  const int fd = ::open(path.c_str(), O_RDWR | O_NOCTTY | O_NONBLOCK | O_CLOEXEC);
  if (fd < 0) {
    return fail(errno == ENOENT ? Errc::not_found : Errc::io_error, errno_text(path));
  }
  termios t{};
  if (::tcgetattr(fd, &t) != 0) {
    const auto e = errno_text(path + ": not a serial port");
    ::close(fd);
    return fail(Errc::io_error, e);
  }
  ::cfmakeraw(&t);
  // XON/XOFF stay off in the kernel: the Spaceball framer drops them itself, and an escaped
  // packet never carries a raw 11h/13h.
  t.c_iflag &= ~static_cast<tcflag_t>(IXON | IXOFF | IXANY);
  t.c_cflag |= CLOCAL | CREAD;
  t.c_cflag &= ~static_cast<tcflag_t>(CSTOPB | CRTSCTS | PARENB | CSIZE);
  t.c_cflag |= CS8;
  if (s.stop_bits == 2) t.c_cflag |= CSTOPB;
  if (s.rts_cts) t.c_cflag |= CRTSCTS;
  t.c_cc[VMIN] = 0;
  t.c_cc[VTIME] = 0;
  ::cfsetispeed(&t, speed);
  ::cfsetospeed(&t, speed);
  if (::tcsetattr(fd, TCSANOW, &t) != 0) {
    const auto e = errno_text(path + ": cannot configure the line");
    ::close(fd);
    return fail(Errc::io_error, e);
  }
  // Raise DTR and RTS as spacenavd does. A pseudo-terminal answers ENOTTY; that is harmless.
  int lines = TIOCM_DTR | TIOCM_RTS;
  (void)::ioctl(fd, TIOCMBIS, &lines);
  ::tcflush(fd, TCIOFLUSH);
  fd_ = fd;
  return {};
}

Result<size_t> SerialLine::read(std::span<uint8_t> out, int timeout_ms) {
  if (fd_ < 0) return fail(Errc::disconnected, "port is closed");
  pollfd p{fd_, POLLIN, 0};
  const int r = ::poll(&p, 1, timeout_ms);
  if (r < 0) {
    if (errno == EINTR) return size_t{0};
    return fail(Errc::io_error, errno_text("poll"));
  }
  if (r == 0) return size_t{0};
  const ssize_t n = ::read(fd_, out.data(), out.size());
  if (n > 0) return static_cast<size_t>(n);
  if (n < 0 && (errno == EAGAIN || errno == EINTR)) return size_t{0};
  // Readable but nothing to read: the other end hung up (unplugged adapter, closed pty).
  if (n == 0) return fail(Errc::disconnected, "device hung up");
  return fail(Errc::disconnected, errno_text("read"));
}

Status SerialLine::write(std::span<const uint8_t> bytes) {
  if (fd_ < 0) return fail(Errc::disconnected, "port is closed");
  size_t done = 0;
  int stalls = 0;
  while (done < bytes.size()) {
    const ssize_t n = ::write(fd_, bytes.data() + done, bytes.size() - done);
    if (n > 0) {
      done += static_cast<size_t>(n);
      continue;
    }
    if (n < 0 && errno != EAGAIN && errno != EINTR) return fail(Errc::io_error, errno_text("write"));
    // The output queue is full (device holding CTS, or nobody reading): wait a little, then give up.
    if (++stalls > 50) return fail(Errc::timeout, "write stalled");
    pollfd p{fd_, POLLOUT, 0};
    ::poll(&p, 1, 20);
  }
  return {};
}

void SerialLine::close() {
  if (fd_ >= 0) {
    ::close(fd_);
    fd_ = -1;
  }
}

}  // namespace mimic::devices::detail
