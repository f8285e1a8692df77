// mimic devices: what trackers and input devices are connected, optionally watched for changes.
#include <atomic>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <ctime>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

#include "cli.h"
#include "command.h"
#include "stop_signal.h"
#include "mimic/devices/usb_discovery.h"
#include "mimic/sim/open_input.h"

namespace mimic::app::cmd_devices {
namespace {

constexpr const char* kName = "devices";
constexpr const char* kAbout =
    "Lists what Mimic can use that is connected to this machine:\n"
    "  - USB devices recognised by vendor/product id (libusb): 3Dconnexion SpaceMouse,\n"
    "    SpaceNavigator, SpacePilot ... and USB-serial adapters a Flock of Birds or a serial\n"
    "    Spaceball/Magellan may sit behind (FTDI, Prolific PL2303, Silicon Labs CP210x, WCH\n"
    "    CH340/CH341/CH9102, Keyspan);\n"
    "  - 3Dconnexion HID devices as hidapi sees them, with the path to give a spacemouse: source;\n"
    "  - serial ports: /dev/ttyS* with a UART fitted, /dev/ttyUSB*, /dev/ttyACM*, and the\n"
    "    links in /dev/serial/by-id.\n"
    "When USB or HID cannot be listed (no libusb/hidapi in this build, no /dev/bus/usb in a\n"
    "container) the output says why, and the rest is still listed.";

struct Options {
  double interval_s = 1.0, duration_s = 0.0;
  std::string read;
  std::vector<std::string> serial_dirs;
  bool json = false, watch = false;
};

// --read excludes the listing's options; --interval needs --watch; --duration goes with either.
std::optional<int> parse(cli::Parser& p, const std::vector<std::string>& argv, Options& o) {
  p->footer("Exit status: 0 (also when nothing is connected), 2 on bad usage.");
  auto* json = p->add_flag("--json", o.json,
                           "one JSON object instead of text (with --watch: one object per change,\n"
                           "one per line)");
  auto* watch = p->add_flag("--watch", o.watch,
                            "keep running and print arrivals (+) and departures (-) until Ctrl-C;\n"
                            "uses libusb hot-plug notification where available and rescans every\n"
                            "--interval seconds in any case (serial ports have no notification)");
  auto* interval = p->add_option("--interval", o.interval_s, "rescan period for --watch in seconds")
                       ->check(cli::finite_range(0, 3600, cli::Bound::exclusive))
                       ->needs(watch);
  auto* dirs = p->add_option("--serial-dir", o.serial_dirs,
                             "also look for ttyS*/ttyUSB*/ttyACM* entries (links to serial\n"
                             "devices or pseudo-terminals) in these comma-separated directories")
                   ->type_name("DIRS")
                   ->delimiter(',');
  auto* duration =
      p->add_option("--duration", o.duration_s, "stop watching (or reading) after S seconds (default: until Ctrl-C)")
          ->default_str("")
          ->check(cli::finite_range(0, INFINITY));
  p->add_option("--read", o.read,
                "open one 6-DOF input device and print what it sends, ten lines a\n"
                "second, then its status; SOURCE is one of\n"
                "  spaceball:PATH   serial Spaceball (params: probe, dead, reset, tscale,\n"
                "                   rscale, null, baud)\n"
                "  magellan:PATH    serial Magellan / SpaceMouse (params: settle, probe,\n"
                "                   dead, scale, null)\n"
                "  spacemouse       first 3Dconnexion USB device; spacemouse:HIDRAW_PATH a\n"
                "                   given one; spacemouse:sim a simulated SpaceNavigator\n"
                "                   (vid=HEX&pid=HEX pick the device or simulated model)\n"
                "Frames: translation T and rotation R in [-1, 1], +X right, +Y up, +Z\n"
                "toward the user; buttons as a bit mask (bit 0 = button 1).")
      ->type_name("SOURCE")
      ->excludes(json)
      ->excludes(watch)
      ->excludes(interval)
      ->excludes(dirs);
  if (auto exit_code = p.parse(argv)) return exit_code;
  if (duration->count() > 0 && o.read.empty() && !o.watch)
    return p.usage_error("--duration only applies with --watch or --read");
  return std::nullopt;
}

nlohmann::json to_json(const devices::DeviceInventory& inv) {
  auto hex = [](uint16_t v) {
    char b[8];
    std::snprintf(b, sizeof b, "%04x", v);
    return std::string(b);
  };
  nlohmann::json j;
  j["usb"] = nlohmann::json::array();
  for (const auto& u : inv.usb.recognised) {
    j["usb"].push_back({{"vendor_id", hex(u.vendor_id)},
                        {"product_id", hex(u.product_id)},
                        {"name", u.name},
                        {"kind", u.kind == devices::UsbKind::six_dof ? "6dof" : "usb-serial"},
                        {"bus", u.bus},
                        {"address", u.address}});
  }
  j["usb_other_devices"] = inv.usb.other_devices;
  if (!inv.usb_error.empty()) j["usb_error"] = inv.usb_error;
  j["hid"] = nlohmann::json::array();
  for (const auto& h : inv.hid) {
    j["hid"].push_back({{"vendor_id", hex(h.vendor_id)},
                        {"product_id", hex(h.product_id)},
                        {"name", h.model ? h.model->name : h.product},
                        {"path", h.path},
                        {"serial", h.serial}});
  }
  if (!inv.hid_error.empty()) j["hid_error"] = inv.hid_error;
  j["serial"] = nlohmann::json::array();
  for (const auto& s : inv.serial) j["serial"].push_back({{"path", s.path}, {"target", s.target}, {"kind", s.kind}});
  j["nothing_connected"] = inv.nothing_to_use();
  return j;
}

void print_text(const devices::DeviceInventory& inv) {
  std::printf("USB (libusb):\n");
  if (!inv.usb_error.empty()) {
    std::printf("  cannot list: %s\n", inv.usb_error.c_str());
  } else {
    for (const auto& u : inv.usb.recognised) {
      std::printf("  %04x:%04x  %-40s bus %u address %u\n", u.vendor_id, u.product_id, u.name.c_str(), u.bus,
                  u.address);
    }
    if (inv.usb.recognised.empty()) std::printf("  no 3Dconnexion device or USB-serial adapter");
    if (inv.usb.recognised.empty()) std::printf(" (%zu other USB devices)\n", inv.usb.other_devices);
  }
  std::printf("HID (hidapi):\n");
  if (!inv.hid_error.empty()) {
    std::printf("  cannot list: %s\n", inv.hid_error.c_str());
  } else if (inv.hid.empty()) {
    std::printf("  no 3Dconnexion HID device\n");
  }
  for (const auto& h : inv.hid) {
    std::printf("  %04x:%04x  %-40s spacemouse:%s\n", h.vendor_id, h.product_id, h.model ? h.model->name : "",
                h.path.c_str());
  }
  std::printf("Serial ports:\n");
  if (inv.serial.empty()) std::printf("  none\n");
  for (const auto& s : inv.serial) {
    if (s.target != s.path)
      std::printf("  %-44s %s -> %s\n", s.path.c_str(), s.kind.c_str(), s.target.c_str());
    else
      std::printf("  %-44s %s\n", s.path.c_str(), s.kind.c_str());
  }
  if (inv.nothing_to_use()) {
    std::printf("\nNo 6-DOF input device or USB-serial adapter is connected.%s\n",
                inv.serial.empty() ? " No serial ports either."
                                   : " A serial tracker may still be on one of the serial ports above.");
  }
  std::fflush(stdout);
}

std::string timestamp() {
  const std::time_t t = std::time(nullptr);
  char b[32];
  std::strftime(b, sizeof b, "%H:%M:%S", std::localtime(&t));
  return b;
}

Result<std::unique_ptr<devices::InputSource>> open_input(const std::string& text) {
  auto spec = devices::parse_source_spec(text);
  if (!spec) return tl::unexpected(spec.error());
  return sim::open_input_source(*spec);
}

int read_source(const std::string& text, double duration_s) {
  auto src = open_input(text);
  if (!src) return usage_error(kName, src.error().what());
  if (auto r = (*src)->start(); !r) return failure(kName, r.error().what());
  install_stop_handler();
  using clock = std::chrono::steady_clock;
  const auto start = clock::now();
  auto next_print = start;
  uint64_t frames = 0;
  devices::InputFrame f;
  bool have = false;
  while (!stop_requested()) {
    const auto now = clock::now();
    if (duration_s > 0 && now - start >= std::chrono::duration<double>(duration_s)) break;
    devices::InputFrame g;
    while ((*src)->poll(g)) {
      f = g;
      have = true;
      ++frames;
    }
    if (have && now >= next_print) {
      next_print = now + std::chrono::milliseconds(100);
      std::printf("%7.3f  T %+.3f %+.3f %+.3f  R %+.3f %+.3f %+.3f  buttons 0x%03x\n",
                  std::chrono::duration<double>(now - start).count(), f.translation.x, f.translation.y, f.translation.z,
                  f.rotation.x, f.rotation.y, f.rotation.z, f.buttons);
      std::fflush(stdout);
      have = false;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  const auto st = (*src)->status();
  static const char* kStates[] = {"disconnected", "connecting", "streaming", "stale", "error"};
  std::printf("status: %s: %s, %llu frames polled, %llu records, %llu resyncs, %llu reconnects%s%s\n",
              st.description.c_str(), kStates[static_cast<int>(st.state)], static_cast<unsigned long long>(frames),
              static_cast<unsigned long long>(st.records), static_cast<unsigned long long>(st.resyncs),
              static_cast<unsigned long long>(st.reconnects),
              st.last_error.empty() ? "" : "; last error: ", st.last_error.c_str());
  (*src)->stop();
  return 0;
}

int run(const std::vector<std::string>& argv) {
  cli::Parser p(kName, kAbout);
  Options o;
  if (auto exit_code = parse(p, argv, o)) return *exit_code;
  if (!o.read.empty()) return read_source(o.read, o.duration_s);
  const bool json = o.json;
  const double interval_s = o.interval_s, duration_s = o.duration_s;
  devices::SerialScan scan;
  for (const std::string& d : o.serial_dirs)
    if (!d.empty()) scan.dirs.push_back(d);

  auto inv = devices::scan_devices(scan);
  if (json) {
    std::printf("%s\n", to_json(inv).dump(json && o.watch ? -1 : 2).c_str());
    std::fflush(stdout);
  } else {
    print_text(inv);
  }
  if (!o.watch) return 0;

  install_stop_handler();
  std::atomic<bool> usb_changed{false};
  auto hotplug = devices::UsbHotplug::start([&] { usb_changed.store(true); });
  if (!json) {
    std::string how = "USB hot-plug notification";
    if (!hotplug) {
      how = "no USB hot-plug: ";
      how += hotplug.error().message;
    }
    std::printf("\nWatching (%s; rescans every %g s). Ctrl-C to stop.\n", how.c_str(), interval_s);
    std::fflush(stdout);
  }
  auto lines = devices::inventory_lines(inv);
  using clock = std::chrono::steady_clock;
  const auto start = clock::now();
  auto next_scan = start + std::chrono::duration<double>(interval_s);
  while (!stop_requested()) {
    if (duration_s > 0 && clock::now() - start >= std::chrono::duration<double>(duration_s)) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
    if (!usb_changed.exchange(false) && clock::now() < next_scan) continue;
    next_scan = clock::now() + std::chrono::duration<double>(interval_s);
    auto now = devices::scan_devices(scan);
    auto now_lines = devices::inventory_lines(now);
    const auto change = devices::diff_inventory(lines, now_lines);
    if (change.arrived.empty() && change.departed.empty()) continue;
    if (json) {
      nlohmann::json j = to_json(now);
      j["arrived"] = change.arrived;
      j["departed"] = change.departed;
      std::printf("%s\n", j.dump().c_str());
    } else {
      for (const auto& a : change.arrived) std::printf("%s + %s\n", timestamp().c_str(), a.c_str());
      for (const auto& d : change.departed) std::printf("%s - %s\n", timestamp().c_str(), d.c_str());
    }
    std::fflush(stdout);
    lines = std::move(now_lines);
  }
  return 0;
}

}  // namespace

MIMIC_COMMAND(devices, kName, "list connected trackers, SpaceMice and serial ports (--watch for hot-plug)", run);

}  // namespace mimic::app::cmd_devices
