// The serial port wrapper against a real pseudo-terminal (the test holds the master side).
#include <fcntl.h>
#include <poll.h>
#include <termios.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <memory>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "mimic/devices/serial.h"

namespace mimic::devices::serial_test {
namespace {

using namespace std::chrono_literals;

struct Master {
  int fd = -1;
  std::string slave;
  Master() {
    fd = ::posix_openpt(O_RDWR | O_NOCTTY);
    if (fd < 0 || ::grantpt(fd) != 0 || ::unlockpt(fd) != 0) return;
    slave = ::ptsname(fd);
  }
  ~Master() {
    if (fd >= 0) ::close(fd);
  }
  std::vector<uint8_t> read(size_t n) {
    std::vector<uint8_t> out;
    while (out.size() < n) {
      pollfd p{fd, POLLIN, 0};
      if (::poll(&p, 1, 500) <= 0) break;
      uint8_t b[64];
      const ssize_t got = ::read(fd, b, std::min(sizeof b, n - out.size()));
      if (got <= 0) break;
      out.insert(out.end(), b, b + got);
    }
    return out;
  }
};

TEST(SerialPort, RawBytesBothWaysIncludingFlowControlCharacters) {
  Master m;
  ASSERT_FALSE(m.slave.empty());
  auto port = SerialPort::open(m.slave, SerialOptions{115200});
  ASSERT_TRUE(port) << port.error().what();
  // XON, XOFF, CR, LF and bytes with bit 7 must pass untouched in both directions.
  const std::vector<uint8_t> bytes = {0x11, 0x13, 0x0D, 0x0A, 0x80, 0xFF, 0x00, 0x7F};
  ASSERT_TRUE((*port)->write(bytes));
  EXPECT_EQ(m.read(bytes.size()), bytes);
  ASSERT_EQ(::write(m.fd, bytes.data(), bytes.size()), static_cast<ssize_t>(bytes.size()));
  std::vector<uint8_t> in(bytes.size());
  ASSERT_TRUE((*port)->read_exact(in, 500ms));
  EXPECT_EQ(in, bytes);

  termios t{};
  ASSERT_EQ(::tcgetattr(m.fd, &t), 0);  // the slave's settings, seen from the master
  EXPECT_EQ(::cfgetospeed(&t), B115200);
  EXPECT_EQ(t.c_cflag & CSIZE, static_cast<tcflag_t>(CS8));
  EXPECT_FALSE(t.c_cflag & PARENB);
  EXPECT_FALSE(t.c_cflag & CSTOPB);
  EXPECT_FALSE(t.c_cflag & CRTSCTS);
  EXPECT_FALSE(t.c_iflag & (IXON | IXOFF));
  EXPECT_FALSE(t.c_lflag & (ICANON | ECHO));
  EXPECT_FALSE(t.c_oflag & OPOST);
}

TEST(SerialPort, TimeoutsAndPartialReads) {
  Master m;
  auto port = SerialPort::open(m.slave, SerialOptions{9600});
  ASSERT_TRUE(port);
  std::vector<uint8_t> buf(16);
  auto n = (*port)->read_some(buf, 30ms);
  ASSERT_TRUE(n);
  EXPECT_EQ(*n, 0u);  // nothing arrived: a timeout is not an error
  const uint8_t two[2] = {1, 2};
  ASSERT_EQ(::write(m.fd, two, 2), 2);
  std::vector<uint8_t> four(4);
  auto r = (*port)->read_exact(four, 50ms);
  ASSERT_FALSE(r);
  EXPECT_EQ(r.error().code, Errc::timeout);
  EXPECT_NE(r.error().message.find("expected 4 bytes, got 2"), std::string::npos) << r.error().message;
  // The port is still usable after a timed-out read.
  ASSERT_TRUE((*port)->write(std::vector<uint8_t>{'B'}));
  EXPECT_EQ(m.read(1), std::vector<uint8_t>{'B'});
}

TEST(SerialPort, FlushInputDropsPendingBytes) {
  Master m;
  auto port = SerialPort::open(m.slave, SerialOptions{});
  ASSERT_TRUE(port);
  const uint8_t junk[5] = {9, 9, 9, 9, 9};
  ASSERT_EQ(::write(m.fd, junk, 5), 5);
  std::this_thread::sleep_for(20ms);
  (*port)->flush_input();
  std::vector<uint8_t> buf(8);
  auto n = (*port)->read_some(buf, 30ms);
  ASSERT_TRUE(n);
  EXPECT_EQ(*n, 0u);
}

TEST(SerialPort, ModemLinesOnAPtyAreNotAnError) {
  Master m;
  auto port = SerialPort::open(m.slave, SerialOptions{});
  ASSERT_TRUE(port);
  auto rts = (*port)->set_rts(true);
  ASSERT_TRUE(rts) << rts.error().what();
  EXPECT_FALSE(*rts);  // ENOTTY on a pty: no modem control, reported as such
  auto dtr = (*port)->set_dtr(true);
  ASSERT_TRUE(dtr);
  EXPECT_FALSE(*dtr);
}

TEST(SerialPort, ClearErrors) {
  auto missing = SerialPort::open("/dev/mimic-no-such-port", SerialOptions{});
  ASSERT_FALSE(missing);
  EXPECT_EQ(missing.error().code, Errc::not_found);
  EXPECT_NE(missing.error().message.find("/dev/mimic-no-such-port"), std::string::npos);
  auto not_tty = SerialPort::open("/dev/null", SerialOptions{});
  ASSERT_FALSE(not_tty);
  EXPECT_EQ(not_tty.error().code, Errc::io_error);
}

TEST(SerialPort, HangUpIsReportedAsDisconnected) {
  auto m = std::make_unique<Master>();
  auto port = SerialPort::open(m->slave, SerialOptions{});
  ASSERT_TRUE(port);
  m.reset();  // the other end goes away
  std::vector<uint8_t> buf(8);
  auto n = (*port)->read_some(buf, 200ms);
  ASSERT_FALSE(n);
  EXPECT_EQ(n.error().code, Errc::disconnected) << n.error().what();
}

}  // namespace
}  // namespace mimic::devices::serial_test
