#include "mimic/devices/usb_discovery.h"

#include <fcntl.h>
#include <stdlib.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <set>
#include <string>

namespace usb_discovery_test {

namespace dev = mimic::devices;
namespace fs = std::filesystem;

namespace {

// A pseudo-terminal standing in for a USB-serial adapter's tty node.
struct TestPty {
  int master = -1;
  std::string slave;
  TestPty() {
    master = ::posix_openpt(O_RDWR | O_NOCTTY);
    if (master < 0 || ::grantpt(master) != 0 || ::unlockpt(master) != 0) return;
    char name[128];
    if (::ptsname_r(master, name, sizeof name) == 0) slave = name;
  }
  void close() {
    if (master >= 0) ::close(master);
    master = -1;
  }
  ~TestPty() { close(); }
};

struct TempDir {
  fs::path path;
  TempDir() {
    std::string tmpl = (fs::temp_directory_path() / "mimic-usb-XXXXXX").string();
    path = ::mkdtemp(tmpl.data());
  }
  ~TempDir() {
    std::error_code ec;
    fs::remove_all(path, ec);
  }
};

}  // namespace

TEST(UsbDiscovery, VendorTableMatching) {
  dev::UsbId id{};
  ASSERT_TRUE(dev::classify_usb(0x0403, 0x6001, id));
  EXPECT_EQ(id.kind, dev::UsbKind::usb_serial);
  EXPECT_NE(std::string(id.name).find("FTDI"), std::string::npos);
  ASSERT_TRUE(dev::classify_usb(0x1A86, 0x7523, id));
  EXPECT_NE(std::string(id.name).find("CH340"), std::string::npos);
  ASSERT_TRUE(dev::classify_usb(0x067B, 0x2303, id));
  ASSERT_TRUE(dev::classify_usb(0x10C4, 0xEA60, id));
  ASSERT_TRUE(dev::classify_usb(0x046D, 0xC626, id));
  EXPECT_EQ(id.kind, dev::UsbKind::six_dof);
  EXPECT_STREQ(id.name, "SpaceNavigator");
  ASSERT_TRUE(dev::classify_usb(0x256F, 0xC635, id));
  EXPECT_FALSE(dev::classify_usb(0x046D, 0xC52B, id));  // a Logitech receiver
  EXPECT_FALSE(dev::classify_usb(0x256F, 0xC650, id));  // CadMouse
  EXPECT_FALSE(dev::classify_usb(0x0000, 0x0000, id));
  // No id is in both tables, and none twice.
  std::set<uint32_t> ids;
  for (const auto& s : dev::usb_serial_ids()) {
    EXPECT_TRUE(ids.insert(uint32_t{s.vendor_id} << 16 | s.product_id).second);
    EXPECT_EQ(mimic::devices::hid::find_model(s.vendor_id, s.product_id), nullptr);
  }
}

TEST(UsbDiscovery, SerialPortEnumerationFindsAPtyBehindAUsbName) {
  TestPty pty;
  ASSERT_FALSE(pty.slave.empty());
  TempDir tmp;
  fs::create_directory(tmp.path / "by-id");
  fs::create_symlink(pty.slave, tmp.path / "ttyUSB7");
  fs::create_symlink(pty.slave, tmp.path / "by-id" / "usb-FTDI_FT232R_USB_UART_A1B2C3-if00-port0");
  { std::ofstream(tmp.path / "ttyUSB3") << "not a device"; }
  fs::create_symlink(tmp.path / "missing", tmp.path / "ttyACM0");
  fs::create_symlink(pty.slave, tmp.path / "lp0");  // a name we do not look for

  dev::SerialScan scan;
  scan.dirs = {tmp.path.string()};
  scan.link_dirs = {(tmp.path / "by-id").string()};
  const auto ports = dev::list_serial_ports(scan);
  ASSERT_EQ(ports.size(), 2u);
  EXPECT_EQ(ports[0].path, (tmp.path / "by-id" / "usb-FTDI_FT232R_USB_UART_A1B2C3-if00-port0").string());
  EXPECT_EQ(ports[1].path, (tmp.path / "ttyUSB7").string());
  EXPECT_EQ(ports[1].kind, "USB serial");
  EXPECT_EQ(ports[1].target, pty.slave);

  // Unplugging (closing the pty) is seen as a departure.
  dev::DeviceInventory before;
  before.serial = ports;
  pty.close();
  dev::DeviceInventory after;
  after.serial = dev::list_serial_ports(scan);
  EXPECT_TRUE(after.serial.empty());
  const auto change = dev::diff_inventory(dev::inventory_lines(before), dev::inventory_lines(after));
  EXPECT_TRUE(change.arrived.empty());
  ASSERT_EQ(change.departed.size(), 2u);
  EXPECT_NE(change.departed[1].find("ttyUSB7 (USB serial, " + ports[1].target + ")"), std::string::npos)
      << change.departed[1];
}

TEST(UsbDiscovery, EmptyInventoryAndWhatThisMachineHas) {
  dev::DeviceInventory empty;
  EXPECT_TRUE(empty.nothing_to_use());
  EXPECT_TRUE(dev::inventory_lines(empty).empty());

  dev::SerialScan nowhere;
  TempDir tmp;
  nowhere.dirs = {tmp.path.string()};
  nowhere.link_dirs = {(tmp.path / "absent").string()};
  const auto inv = dev::scan_devices(nowhere);
  EXPECT_TRUE(inv.serial.empty());
  // USB and HID listing either work or say why not; whatever they list is classified.
  if (inv.usb_error.empty()) {
    for (const auto& u : inv.usb.recognised) {
      dev::UsbId id{};
      EXPECT_TRUE(dev::classify_usb(u.vendor_id, u.product_id, id));
    }
  }
  for (const auto& h : inv.hid) EXPECT_NE(h.model, nullptr);
  EXPECT_EQ(inv.nothing_to_use(), inv.usb.recognised.empty() && inv.hid.empty());
}

TEST(UsbDiscovery, InventoryDiffIsASetDifference) {
  const std::vector<std::string> a = {"serial /dev/ttyS0 (UART)", "usb 0403:6001 FTDI (bus 1 address 2)"};
  const std::vector<std::string> b = {"serial /dev/ttyS0 (UART)", "usb 046d:c626 SpaceNavigator (bus 1 address 3)"};
  const auto c = dev::diff_inventory(a, b);
  ASSERT_EQ(c.arrived.size(), 1u);
  ASSERT_EQ(c.departed.size(), 1u);
  EXPECT_NE(c.arrived[0].find("SpaceNavigator"), std::string::npos);
  EXPECT_NE(c.departed[0].find("FTDI"), std::string::npos);
}

}  // namespace usb_discovery_test
