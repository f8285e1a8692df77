// What is plugged in: USB devices recognised by vendor/product id (3Dconnexion 6-DOF devices,
// USB-serial adapters a Flock of Birds or serial Spaceball may sit behind), HID devices as
// hidapi sees them, and serial ports. Used by `mimic devices`. Each part degrades on its own:
// a build without libusb or hidapi, or a machine without /dev/bus/usb, still lists serial ports
// and says why the rest is missing.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "mimic/core/result.h"
#include "mimic/devices/hid_spacemouse.h"

namespace mimic::devices {

enum class UsbKind : uint8_t { six_dof, usb_serial };

struct UsbId {
  uint16_t vendor_id;
  uint16_t product_id;
  const char* name;
  UsbKind kind;
};

// The USB-serial adapter table (FTDI, Prolific, Silicon Labs CP210x, WCH CH34x, Keyspan).
std::span<const UsbId> usb_serial_ids() noexcept;
// A 3Dconnexion device (hid::models()) or a USB-serial adapter; nullopt-like false otherwise.
bool classify_usb(uint16_t vendor_id, uint16_t product_id, UsbId& out) noexcept;

struct UsbDeviceInfo {
  uint16_t vendor_id = 0;
  uint16_t product_id = 0;
  uint8_t bus = 0;
  uint8_t address = 0;
  std::string name;
  UsbKind kind = UsbKind::usb_serial;
};

struct UsbListing {
  std::vector<UsbDeviceInfo> recognised;
  size_t other_devices = 0;  // USB devices that are neither
};

// Errc::unsupported without libusb; Errc::io_error when libusb cannot start.
Result<UsbListing> list_usb_devices();

struct SerialPortInfo {
  std::string path;    // as found (/dev/ttyUSB0, /dev/serial/by-id/usb-FTDI_…)
  std::string target;  // the device node it resolves to
  std::string kind;    // "UART", "USB serial", "USB CDC ACM", "serial"
};

// Where serial ports are looked for. Tests point this at a directory holding a pty link.
struct SerialScan {
  std::vector<std::string> dirs = {"/dev"};
  std::vector<std::string> prefixes = {"ttyS", "ttyUSB", "ttyACM"};
  std::vector<std::string> link_dirs = {"/dev/serial/by-id"};  // every entry, whatever its name
};

// Only character devices a serial (or pseudo-terminal slave) driver owns, by /proc/tty/drivers;
// ttyS ports without a UART (sysfs type 0) are left out. Ports are never opened, since opening
// raises DTR/RTS and RTS resets a Flock of Birds.
std::vector<SerialPortInfo> list_serial_ports(const SerialScan& scan = {});

struct DeviceInventory {
  UsbListing usb;
  std::string usb_error;           // why USB could not be listed; empty when it was
  std::vector<HidDeviceInfo> hid;  // known 6-DOF devices only
  std::string hid_error;
  std::vector<SerialPortInfo> serial;

  // True when there is no 6-DOF device and no USB-serial adapter.
  bool nothing_to_use() const;
};

DeviceInventory scan_devices(const SerialScan& scan = {});

// One stable line per item ("usb 046d:c626 SpaceNavigator (bus 1 address 4)", "serial
// /dev/ttyUSB0 (USB serial)"), sorted; arrivals and departures are set differences.
std::vector<std::string> inventory_lines(const DeviceInventory& inv);
struct InventoryChange {
  std::vector<std::string> arrived;
  std::vector<std::string> departed;
};
InventoryChange diff_inventory(const std::vector<std::string>& before, const std::vector<std::string>& after);

// libusb hot-plug notification: on_change runs (on a private thread) when a USB device comes or
// goes. Errc::unsupported when libusb or the platform has no hot-plug support; callers then
// rescan periodically.
class UsbHotplug {
 public:
  static Result<std::unique_ptr<UsbHotplug>> start(std::function<void()> on_change);
  virtual ~UsbHotplug() = default;
};

}  // namespace mimic::devices
