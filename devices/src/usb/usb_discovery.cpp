#include "mimic/devices/usb_discovery.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <sys/sysmacros.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <cstdio>
#include <filesystem>
#include <charconv>
#include <fstream>
#include <set>
#include <sstream>
#include <thread>

#ifdef MIMIC_WITH_LIBUSB
#include <libusb-1.0/libusb.h>
#endif

namespace mimic::devices {

namespace fs = std::filesystem;

namespace {

constexpr UsbId kSerialIds[] = {
    {0x0403, 0x6001, "FTDI FT232R/FT232BM USB-serial", UsbKind::usb_serial},
    {0x0403, 0x6010, "FTDI FT2232 USB-serial", UsbKind::usb_serial},
    {0x0403, 0x6011, "FTDI FT4232 USB-serial", UsbKind::usb_serial},
    {0x0403, 0x6014, "FTDI FT232H USB-serial", UsbKind::usb_serial},
    {0x0403, 0x6015, "FTDI FT-X USB-serial", UsbKind::usb_serial},
    {0x067B, 0x2303, "Prolific PL2303 USB-serial", UsbKind::usb_serial},
    {0x067B, 0x23A3, "Prolific PL2303GC USB-serial", UsbKind::usb_serial},
    {0x10C4, 0xEA60, "Silicon Labs CP210x USB-serial", UsbKind::usb_serial},
    {0x10C4, 0xEA70, "Silicon Labs CP2105 USB-serial", UsbKind::usb_serial},
    {0x10C4, 0xEA71, "Silicon Labs CP2108 USB-serial", UsbKind::usb_serial},
    {0x1A86, 0x7523, "WCH CH340 USB-serial", UsbKind::usb_serial},
    {0x1A86, 0x5523, "WCH CH341 USB-serial", UsbKind::usb_serial},
    {0x1A86, 0x55D4, "WCH CH9102 USB-serial", UsbKind::usb_serial},
    {0x06CD, 0x0121, "Keyspan USA-19HS USB-serial", UsbKind::usb_serial},
};

std::string hex_ids(uint16_t v, uint16_t p) {
  char b[16];
  std::snprintf(b, sizeof b, "%04x:%04x", v, p);
  return b;
}

std::string read_small_file(const std::string& path) {
  std::ifstream in(path);
  std::string s;
  std::getline(in, s);
  return s;
}

// True when `path` is a character device that a serial or pseudo-terminal slave driver owns,
// according to /proc/tty/drivers. The port is never opened: opening a tty raises DTR and RTS,
// and RTS holds a Flock of Birds in reset.
bool is_serial_node(const std::string& path) {
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0 || !S_ISCHR(st.st_mode)) return false;
  const unsigned major = ::major(st.st_rdev), minor = ::minor(st.st_rdev);
  std::ifstream drivers("/proc/tty/drivers");
  std::string line;
  while (std::getline(drivers, line)) {
    std::istringstream in(line);
    std::string name, node, range, type;
    unsigned maj = 0;
    if (!(in >> name >> node >> maj >> range >> type)) continue;
    if (maj != major || (type != "serial" && type != "pty:slave")) continue;
    // "64-111" or "5": a line that is neither is skipped (never an exception).
    unsigned lo = 0, hi = 0;
    const auto dash = range.find('-');
    const std::string first = range.substr(0, dash), last = dash == std::string::npos ? first : range.substr(dash + 1);
    const auto a = std::from_chars(first.data(), first.data() + first.size(), lo);
    const auto b = std::from_chars(last.data(), last.data() + last.size(), hi);
    if (a.ec != std::errc() || b.ec != std::errc()) continue;
    if (minor >= lo && minor <= hi) return true;
  }
  return false;
}

std::string kind_of(const std::string& node_name) {
  if (node_name.rfind("ttyUSB", 0) == 0) return "USB serial";
  if (node_name.rfind("ttyACM", 0) == 0) return "USB CDC ACM";
  if (node_name.rfind("ttyS", 0) == 0) return "UART";
  return "serial";
}

}  // namespace

std::span<const UsbId> usb_serial_ids() noexcept { return kSerialIds; }

bool classify_usb(uint16_t vid, uint16_t pid, UsbId& out) noexcept {
  if (const auto* m = hid::find_model(vid, pid)) {
    out = {vid, pid, m->name, UsbKind::six_dof};
    return true;
  }
  for (const auto& id : kSerialIds) {
    if (id.vendor_id == vid && id.product_id == pid) {
      out = id;
      return true;
    }
  }
  return false;
}

std::vector<SerialPortInfo> list_serial_ports(const SerialScan& scan) {
  std::vector<SerialPortInfo> out;
  std::set<std::string> seen;
  std::error_code ec;
  for (const auto& dir : scan.dirs) {
    for (const auto& e : fs::directory_iterator(dir, ec)) {
      const std::string name = e.path().filename().string();
      const bool wanted = std::any_of(scan.prefixes.begin(), scan.prefixes.end(),
                                      [&](const std::string& p) { return name.rfind(p, 0) == 0; });
      if (!wanted) continue;
      const std::string path = e.path().string();
      std::error_code ec2;
      const std::string target = fs::canonical(e.path(), ec2).string();
      if (ec2) continue;
      const std::string node = fs::path(target).filename().string();
      // 8250 ports exist whether or not a UART is fitted; sysfs type 0 means none is.
      if (node.rfind("ttyS", 0) == 0) {
        const std::string type = read_small_file("/sys/class/tty/" + node + "/type");
        if (type == "0") continue;
      }
      if (!is_serial_node(target)) continue;
      if (seen.insert(path).second) out.push_back({path, target, kind_of(name)});
    }
  }
  for (const auto& dir : scan.link_dirs) {
    for (const auto& e : fs::directory_iterator(dir, ec)) {
      std::error_code ec2;
      const std::string target = fs::canonical(e.path(), ec2).string();
      if (ec2 || !is_serial_node(target)) continue;
      const std::string path = e.path().string();
      if (seen.insert(path).second) {
        out.push_back({path, target, kind_of(fs::path(target).filename().string())});
      }
    }
  }
  std::sort(out.begin(), out.end(), [](const auto& a, const auto& b) { return a.path < b.path; });
  return out;
}

#ifdef MIMIC_WITH_LIBUSB

Result<UsbListing> list_usb_devices() {
  libusb_context* ctx = nullptr;
  if (const int r = libusb_init(&ctx); r != 0) {
    return fail(Errc::io_error, std::string("libusb: ") + libusb_error_name(r));
  }
  UsbListing out;
  libusb_device** list = nullptr;
  const ssize_t n = libusb_get_device_list(ctx, &list);
  if (n < 0) {
    libusb_exit(ctx);
    return fail(Errc::io_error, std::string("libusb: ") + libusb_error_name(static_cast<int>(n)));
  }
  for (ssize_t i = 0; i < n; ++i) {
    libusb_device_descriptor d{};
    if (libusb_get_device_descriptor(list[i], &d) != 0) continue;
    UsbId id{};
    if (!classify_usb(d.idVendor, d.idProduct, id)) {
      ++out.other_devices;
      continue;
    }
    out.recognised.push_back({d.idVendor, d.idProduct, libusb_get_bus_number(list[i]),
                              libusb_get_device_address(list[i]), id.name, id.kind});
  }
  libusb_free_device_list(list, 1);
  libusb_exit(ctx);
  return out;
}

namespace {

class LibusbHotplug final : public UsbHotplug {
 public:
  LibusbHotplug(libusb_context* ctx, std::function<void()> cb) : ctx_(ctx), cb_(std::move(cb)) {}
  ~LibusbHotplug() override {
    running_.store(false);
    if (handle_registered_) libusb_hotplug_deregister_callback(ctx_, handle_);  // wakes the event loop
    if (thread_.joinable()) thread_.join();
    libusb_exit(ctx_);
  }

  Status arm() {
    const int r = libusb_hotplug_register_callback(
        ctx_, static_cast<libusb_hotplug_event>(LIBUSB_HOTPLUG_EVENT_DEVICE_ARRIVED | LIBUSB_HOTPLUG_EVENT_DEVICE_LEFT),
        LIBUSB_HOTPLUG_NO_FLAGS, LIBUSB_HOTPLUG_MATCH_ANY, LIBUSB_HOTPLUG_MATCH_ANY, LIBUSB_HOTPLUG_MATCH_ANY,
        &LibusbHotplug::on_event, this, &handle_);
    if (r != LIBUSB_SUCCESS) return fail(Errc::unsupported, std::string("libusb hot-plug: ") + libusb_error_name(r));
    handle_registered_ = true;
    thread_ = std::thread([this] {
      while (running_.load()) {
        timeval tv{0, 200000};
        libusb_handle_events_timeout_completed(ctx_, &tv, nullptr);
      }
    });
    return {};
  }

 private:
  static int LIBUSB_CALL on_event(libusb_context*, libusb_device*, libusb_hotplug_event, void* self) {
    static_cast<LibusbHotplug*>(self)->cb_();
    return 0;
  }

  libusb_context* ctx_;
  std::function<void()> cb_;
  libusb_hotplug_callback_handle handle_{};
  bool handle_registered_ = false;
  std::atomic<bool> running_{true};
  std::thread thread_;
};

}  // namespace

Result<std::unique_ptr<UsbHotplug>> UsbHotplug::start(std::function<void()> on_change) {
  if (!libusb_has_capability(LIBUSB_CAP_HAS_HOTPLUG)) {
    return fail(Errc::unsupported, "libusb has no hot-plug support here");
  }
  libusb_context* ctx = nullptr;
  if (const int r = libusb_init(&ctx); r != 0) {
    return fail(Errc::io_error, std::string("libusb: ") + libusb_error_name(r));
  }
  auto h = std::make_unique<LibusbHotplug>(ctx, std::move(on_change));
  if (auto r = h->arm(); !r) return tl::unexpected(r.error());
  return std::unique_ptr<UsbHotplug>(std::move(h));
}

#else

Result<UsbListing> list_usb_devices() {
  return fail(Errc::unsupported, "this build has no libusb (MIMIC_WITH_LIBUSB=OFF)");
}

Result<std::unique_ptr<UsbHotplug>> UsbHotplug::start(std::function<void()>) {
  return fail(Errc::unsupported, "this build has no libusb (MIMIC_WITH_LIBUSB=OFF)");
}

#endif

bool DeviceInventory::nothing_to_use() const { return usb.recognised.empty() && hid.empty(); }

DeviceInventory scan_devices(const SerialScan& scan) {
  DeviceInventory inv;
  if (auto u = list_usb_devices())
    inv.usb = std::move(*u);
  else
    inv.usb_error = u.error().message;
  if (auto h = list_hid_devices()) {
    for (auto& d : *h) {
      if (d.model) inv.hid.push_back(std::move(d));
    }
  } else {
    inv.hid_error = h.error().message;
  }
  inv.serial = list_serial_ports(scan);
  return inv;
}

std::vector<std::string> inventory_lines(const DeviceInventory& inv) {
  std::vector<std::string> out;
  for (const auto& u : inv.usb.recognised) {
    out.push_back("usb " + hex_ids(u.vendor_id, u.product_id) + " " + u.name + " (bus " + std::to_string(u.bus) +
                  " address " + std::to_string(u.address) + ")");
  }
  for (const auto& h : inv.hid) {
    out.push_back("hid " + hex_ids(h.vendor_id, h.product_id) + " " + (h.model ? h.model->name : h.product.c_str()) +
                  " " + h.path);
  }
  for (const auto& s : inv.serial) {
    out.push_back("serial " + s.path + " (" + s.kind + (s.target != s.path ? ", " + s.target : std::string()) + ")");
  }
  std::sort(out.begin(), out.end());
  return out;
}

InventoryChange diff_inventory(const std::vector<std::string>& before, const std::vector<std::string>& after) {
  InventoryChange c;
  std::set_difference(after.begin(), after.end(), before.begin(), before.end(), std::back_inserter(c.arrived));
  std::set_difference(before.begin(), before.end(), after.begin(), after.end(), std::back_inserter(c.departed));
  return c;
}

}  // namespace mimic::devices
