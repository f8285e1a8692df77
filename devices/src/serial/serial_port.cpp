#include <utility>  // before Asio: Boost 1.74 needs it

#include <sys/ioctl.h>
#include <termios.h>

#include <cerrno>
#include <cstring>
#include <filesystem>

#include <boost/asio/io_context.hpp>
#include <boost/asio/read.hpp>
#include <boost/asio/serial_port.hpp>
#include <boost/asio/write.hpp>

#include "mimic/core/clock.h"
#include "mimic/devices/serial.h"

namespace mimic::devices {

namespace asio = boost::asio;

struct SerialPort::Impl {
  asio::io_context io;
  asio::serial_port port{io};
  std::string path;
  std::shared_ptr<ByteTap> tap;

  void tapped(bool from_device, const uint8_t* data, size_t n) {
    if (!tap || n == 0) return;
    const double t = steady_now_s();
    tap->on_bytes(from_device, std::span<const uint8_t>(data, n), t);
  }

  // Runs one async read until it completes or the deadline passes; returns bytes read.
  template <class Start>
  Result<size_t> run_read(Start&& start, std::chrono::microseconds timeout, bool& timed_out) {
    boost::system::error_code ec;
    size_t n = 0;
    bool done = false;
    start([&](const boost::system::error_code& e, size_t got) {
      ec = e;
      n = got;
      done = true;
    });
    io.restart();
    io.run_for(timeout);
    timed_out = !done;
    if (!done) {
      // Cancel and let the handler run with operation_aborted, so nothing refers to our stack.
      boost::system::error_code ignored;
      port.cancel(ignored);
      io.restart();
      io.run();
    }
    if (ec && ec != asio::error::operation_aborted) {
      if (ec == asio::error::eof || ec.value() == EIO || ec.value() == ENXIO || ec.value() == EBADF)
        return fail(Errc::disconnected, path + ": " + ec.message());
      return fail(Errc::io_error, path + ": read: " + ec.message());
    }
    return n;
  }
};

SerialPort::SerialPort(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
SerialPort::~SerialPort() {
  if (impl_) {
    boost::system::error_code ignored;
    impl_->port.close(ignored);
  }
}

const std::string& SerialPort::path() const { return impl_->path; }

Result<std::unique_ptr<SerialPort>> SerialPort::open(const std::string& path, const SerialOptions& o) {
  std::error_code fs_ec;
  if (!std::filesystem::exists(path, fs_ec)) return fail(Errc::not_found, path + ": no such device");
  auto impl = std::make_unique<Impl>();
  impl->path = path;
  boost::system::error_code ec;
  impl->port.open(path, ec);  // Asio sets raw mode (no echo, no canonical input, no OPOST)
  if (ec) return fail(Errc::io_error, path + ": open: " + ec.message());
  using sp = asio::serial_port_base;
  impl->port.set_option(sp::baud_rate(static_cast<unsigned>(o.baud)), ec);
  if (ec) return fail(Errc::io_error, path + ": baud " + std::to_string(o.baud) + ": " + ec.message());
  impl->port.set_option(sp::character_size(8), ec);
  if (!ec) impl->port.set_option(sp::parity(sp::parity::none), ec);
  if (!ec) impl->port.set_option(sp::stop_bits(o.stop_bits == 2 ? sp::stop_bits::two : sp::stop_bits::one), ec);
  if (!ec)
    impl->port.set_option(sp::flow_control(o.rtscts    ? sp::flow_control::hardware
                                           : o.xonxoff ? sp::flow_control::software
                                                       : sp::flow_control::none),
                          ec);
  if (ec) return fail(Errc::io_error, path + ": line setup: " + ec.message());
  // Records carry 11h/13h: make sure no flow-control or CR translation survives from a
  // previous user of the port, and reads return as soon as one byte is there.
  const int fd = impl->port.native_handle();
  termios t{};
  if (::tcgetattr(fd, &t) == 0) {
    if (!o.xonxoff) t.c_iflag &= ~static_cast<tcflag_t>(IXON | IXOFF | IXANY);
    t.c_iflag &= ~static_cast<tcflag_t>(ICRNL | INLCR | IGNCR | ISTRIP);
    t.c_cc[VMIN] = 1;
    t.c_cc[VTIME] = 0;
    ::tcsetattr(fd, TCSANOW, &t);
  }
  return std::unique_ptr<SerialPort>(new SerialPort(std::move(impl)));
}

Result<size_t> SerialPort::read_some(std::span<uint8_t> out, std::chrono::microseconds timeout) {
  bool timed_out = false;
  auto r =
      impl_->run_read([&](auto handler) { impl_->port.async_read_some(asio::buffer(out.data(), out.size()), handler); },
                      timeout, timed_out);
  if (!r) return r;
  const size_t n = timed_out ? size_t{0} : *r;
  impl_->tapped(true, out.data(), n);
  return n;
}

Status SerialPort::read_exact(std::span<uint8_t> out, std::chrono::microseconds timeout) {
  bool timed_out = false;
  auto r = impl_->run_read(
      [&](auto handler) { asio::async_read(impl_->port, asio::buffer(out.data(), out.size()), handler); }, timeout,
      timed_out);
  if (!r) return tl::unexpected(r.error());
  impl_->tapped(true, out.data(), std::min(*r, out.size()));
  if (timed_out || *r < out.size()) {
    return fail(Errc::timeout,
                impl_->path + ": expected " + std::to_string(out.size()) + " bytes, got " + std::to_string(*r));
  }
  return {};
}

Status SerialPort::write(std::span<const uint8_t> bytes) {
  boost::system::error_code ec;
  asio::write(impl_->port, asio::buffer(bytes.data(), bytes.size()), ec);
  if (ec) {
    if (ec.value() == EIO || ec.value() == ENXIO) return fail(Errc::disconnected, impl_->path + ": " + ec.message());
    return fail(Errc::io_error, impl_->path + ": write: " + ec.message());
  }
  impl_->tapped(false, bytes.data(), bytes.size());
  return {};
}

void SerialPort::set_tap(std::shared_ptr<ByteTap> tap) { impl_->tap = std::move(tap); }

void SerialPort::flush_input() { ::tcflush(impl_->port.native_handle(), TCIFLUSH); }

namespace {
Result<bool> set_modem_bit(int fd, int bit, bool on, const std::string& path) {
  const int request = on ? TIOCMBIS : TIOCMBIC;
  if (::ioctl(fd, request, &bit) == 0) return true;
  if (errno == ENOTTY || errno == EINVAL || errno == ENOTSUP) return false;  // pty, some adapters
  return fail(Errc::io_error, path + ": modem control: " + std::strerror(errno));
}
}  // namespace

Result<bool> SerialPort::set_rts(bool asserted) {
  return set_modem_bit(impl_->port.native_handle(), TIOCM_RTS, asserted, impl_->path);
}

Result<bool> SerialPort::set_dtr(bool asserted) {
  return set_modem_bit(impl_->port.native_handle(), TIOCM_DTR, asserted, impl_->path);
}

}  // namespace mimic::devices
