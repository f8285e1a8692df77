// End to end: `mimic sim spaceball` serves a virtual Spaceball on a pty; `mimic devices --read`
// drives it with the real driver; `mimic devices` lists what is connected.
#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <termios.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "run_mimic.h"
#include "test_data.h"

extern char** environ;

namespace sim_spaceball_cli_test {

namespace {

// A child process whose stdout we read line by line.
using mimic::test::Child;

}  // namespace

TEST(SimSpaceballCli, DriverReadsTheVirtualSpaceballEndToEnd) {
  const std::string mimic = mimic::test::mimic_binary();
  const auto log = std::filesystem::temp_directory_path() / ("mimic-sb-" + std::to_string(::getpid()) + ".log");
  Child sim({mimic, "sim", "spaceball", "--model", "3003", "--seed", "5", "--power-up", "0.1", "--log", log.string()});
  ASSERT_GT(sim.pid, 0);
  const std::string path = sim.line();  // the first line is the pty path
  ASSERT_EQ(path.rfind("/dev/pts/", 0), 0u) << path;

  Child reader({mimic, "devices", "--read", "spaceball:" + path + "?probe=0.5", "--duration", "2.5"});
  const std::string out = reader.rest();
  EXPECT_EQ(reader.wait(), 0) << out;
  EXPECT_NE(out.find("status: spaceball:" + path + " Spaceball 3003 firmware 2.63: streaming"), std::string::npos)
      << out;
  EXPECT_NE(out.find(" T "), std::string::npos) << out;
  EXPECT_NE(out.find("0 resyncs, 0 reconnects"), std::string::npos) << out;

  ASSERT_EQ(::kill(sim.pid, SIGTERM), 0);
  EXPECT_EQ(sim.wait(), 0);
  // The byte log shows the driver's reset and the device's banner and D packets.
  std::ifstream in(log);
  std::stringstream ss;
  ss << in.rdbuf();
  const std::string text = ss.str();
  EXPECT_NE(text.find(" in 0d 40 52 45 53 45 54 0d"), std::string::npos);  // \r@RESET\r
  // Everything the device sent, as one hex stream: XON CR "@1" … and D packets after a CR.
  std::string sent;
  std::istringstream lines(text);
  for (std::string l; std::getline(lines, l);) {
    const auto at = l.find(" out");
    if (at != std::string::npos) sent += l.substr(at + 4);
  }
  EXPECT_EQ(sent.rfind(" 11 0d 40 31", 0), 0u) << sent.substr(0, 40);
  EXPECT_NE(sent.find(" 0d 44"), std::string::npos);
  std::filesystem::remove(log);
}

// By default the virtual Spaceball is a device that was already plugged in: a program that
// opens the port (as spacenavd does, which gives up on a silent device) is answered at once,
// on the first and on every later open.
TEST(SimSpaceballCli, PluggedInByDefaultAnswersEveryOpenAtOnce) {
  const std::string mimic = mimic::test::mimic_binary();
  Child sim({mimic, "sim", "spaceball"});
  ASSERT_GT(sim.pid, 0);
  const std::string path = sim.line();
  ASSERT_EQ(path.rfind("/dev/pts/", 0), 0u) << path;
  for (int open_count = 0; open_count < 2; ++open_count) {
    const int fd = ::open(path.c_str(), O_RDWR | O_NOCTTY);
    ASSERT_GE(fd, 0);
    termios tio{};
    ASSERT_EQ(::tcgetattr(fd, &tio), 0);
    ::cfmakeraw(&tio);
    ::cfsetispeed(&tio, B9600);
    ::cfsetospeed(&tio, B9600);
    ASSERT_EQ(::tcsetattr(fd, TCSANOW, &tio), 0);
    const auto opened = std::chrono::steady_clock::now();
    ASSERT_EQ(::write(fd, "\"\r", 2), 2);
    std::string got;
    while (got.find("\"2") == std::string::npos &&
           std::chrono::steady_clock::now() - opened < std::chrono::milliseconds(1500)) {
      pollfd p{fd, POLLIN, 0};
      if (::poll(&p, 1, 50) > 0) {
        char buf[256];
        const ssize_t n = ::read(fd, buf, sizeof buf);
        if (n > 0) got.append(buf, static_cast<size_t>(n));
      }
    }
    const double waited_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - opened).count();
    ::close(fd);
    EXPECT_NE(got.find("\"1 Spaceball 4000 FLX"), std::string::npos) << "open " << open_count << ": " << got;
    EXPECT_EQ(got.find("alive and well"), std::string::npos) << got;  // no power-up banner
    EXPECT_LT(waited_s, 1.0);                                         // not the 2 s of a cold start
  }
  ASSERT_EQ(::kill(sim.pid, SIGTERM), 0);
  EXPECT_EQ(sim.wait(), 0);
}

TEST(SimSpaceballCli, UsageErrorsAndHelp) {
  const std::string mimic = mimic::test::mimic_binary();
  {
    Child c({mimic, "sim", "spaceball", "--model", "5000"});
    EXPECT_EQ(c.wait(), 2);
  }
  {
    Child c({mimic, "sim", "spaceball", "--help"});
    const std::string help = c.rest();
    EXPECT_EQ(c.wait(), 0);
    EXPECT_NE(help.find("--model 4000flx|3003|2003"), std::string::npos);
    EXPECT_NE(help.find("--log FILE"), std::string::npos);
  }
  {
    Child c({mimic, "sim", "--help"});
    const std::string help = c.rest();
    EXPECT_EQ(c.wait(), 0);
    EXPECT_NE(help.find("spaceball"), std::string::npos);
    EXPECT_NE(help.find("magellan"), std::string::npos);
  }
}

TEST(DevicesCli, ListsAndSaysWhenNothingIsConnected) {
  const std::string mimic = mimic::test::mimic_binary();
  Child c({mimic, "devices", "--json"});
  const std::string out = c.rest();
  EXPECT_EQ(c.wait(), 0);
  EXPECT_NE(out.find("\"nothing_connected\""), std::string::npos) << out;
  EXPECT_NE(out.find("\"serial\""), std::string::npos) << out;
  Child t({mimic, "devices"});
  const std::string text = t.rest();
  EXPECT_EQ(t.wait(), 0);
  EXPECT_NE(text.find("Serial ports:"), std::string::npos) << text;
  const bool none = out.find("\"nothing_connected\": true") != std::string::npos;
  EXPECT_EQ(none, text.find("No 6-DOF input device or USB-serial adapter is connected.") != std::string::npos);
}

TEST(DevicesCli, WatchSeesASerialPortArriveAndLeave) {
  const std::string mimic = mimic::test::mimic_binary();
  const auto dir = std::filesystem::temp_directory_path() / ("mimic-watch-" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  // A long duration (stopped by SIGINT below): on a loaded machine the two programs' start-ups
  // alone can take seconds.
  Child watch({mimic, "devices", "--watch", "--serial-dir", dir.string(), "--interval", "0.1", "--duration", "60"});
  // Wait for the initial listing, then plug a "USB-serial adapter" in: a virtual Spaceball's pty
  // behind a ttyUSB name; then unplug it.
  std::string l;
  while ((l = watch.line()).find("Watching (") == std::string::npos) ASSERT_FALSE(l.empty() && !watch.out);
  Child sim({mimic, "sim", "spaceball"});
  const std::string path = sim.line();
  ASSERT_EQ(path.rfind("/dev/pts/", 0), 0u) << path;
  std::filesystem::create_symlink(path, dir / "ttyUSB5");
  std::string arrived;
  while ((l = watch.line()).find(" + ") == std::string::npos) ASSERT_FALSE(l.empty());
  arrived = l;
  EXPECT_NE(arrived.find("+ serial " + (dir / "ttyUSB5").string() + " (USB serial, " + path + ")"), std::string::npos)
      << arrived;
  ::kill(sim.pid, SIGTERM);
  EXPECT_EQ(sim.wait(), 0);
  std::string departed;
  while ((l = watch.line()).find(" - ") == std::string::npos) ASSERT_FALSE(l.empty());
  departed = l;
  EXPECT_NE(departed.find("- serial " + (dir / "ttyUSB5").string()), std::string::npos) << departed;
  ::kill(watch.pid, SIGINT);
  EXPECT_EQ(watch.wait(), 0);
  std::filesystem::remove_all(dir);
}

TEST(DevicesCli, WatchStopsAfterDurationAndReadsMagellan) {
  const std::string mimic = mimic::test::mimic_binary();
  Child w({mimic, "devices", "--watch", "--interval", "0.2", "--duration", "0.6"});
  const std::string out = w.rest();
  EXPECT_EQ(w.wait(), 0);
  EXPECT_NE(out.find("Watching ("), std::string::npos) << out;

  Child sim({mimic, "sim", "magellan", "--seed", "3"});
  const std::string path = sim.line();
  ASSERT_EQ(path.rfind("/dev/pts/", 0), 0u) << path;
  Child reader({mimic, "devices", "--read", "magellan:" + path + "?settle=0.1", "--duration", "1.5"});
  const std::string r = reader.rest();
  EXPECT_EQ(reader.wait(), 0);
  EXPECT_NE(r.find("MAGELLAN Version 6.60"), std::string::npos) << r;
  EXPECT_NE(r.find(": streaming"), std::string::npos) << r;
  ::kill(sim.pid, SIGINT);
  EXPECT_EQ(sim.wait(), 0);
}

}  // namespace sim_spaceball_cli_test
