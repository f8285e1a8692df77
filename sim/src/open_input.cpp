#include "mimic/sim/open_input.h"

#include <cstdlib>
#include <string>

#include "mimic/devices/hid_spacemouse.h"
#include "mimic/devices/magellan.h"
#include "mimic/devices/spaceball.h"
#include "mimic/sim/virtual_hid.h"

namespace mimic::sim {

namespace {

Result<uint16_t> hex_id(const devices::SourceSpec& spec, const char* key, uint16_t fallback) {
  auto it = spec.params.find(key);
  if (it == spec.params.end()) return fallback;
  char* end = nullptr;
  const unsigned long v = std::strtoul(it->second.c_str(), &end, 16);
  if (it->second.empty() || *end != '\0' || v > 0xFFFF) {
    return fail(Errc::invalid_argument, spec.text + ": " + key + "=" + it->second + " must be a 16-bit hex id");
  }
  return static_cast<uint16_t>(v);
}

}  // namespace

Result<std::unique_ptr<devices::InputSource>> open_input_source(const devices::SourceSpec& spec) {
  using Ptr = std::unique_ptr<devices::InputSource>;
  if (spec.scheme == "spaceball") {
    auto o = devices::spaceball_options(spec);
    if (!o) return tl::unexpected(o.error());
    return Ptr(devices::make_spaceball_source(*o));
  }
  if (spec.scheme == "magellan") {
    auto o = devices::magellan_options(spec);
    if (!o) return tl::unexpected(o.error());
    return Ptr(devices::make_magellan_source(*o));
  }
  if (spec.scheme == "spacemouse") {
    const bool simulated = spec.target == "sim";
    auto vid = hex_id(spec, "vid", simulated ? devices::hid::kVendorLogitech : 0);
    if (!vid) return tl::unexpected(vid.error());
    auto pid = hex_id(spec, "pid", simulated ? 0xC626 : 0);
    if (!pid) return tl::unexpected(pid.error());
    if (simulated) {
      VirtualHidConfig cfg;
      cfg.vendor_id = *vid;
      cfg.product_id = *pid;
      if (auto it = spec.params.find("seed"); it != spec.params.end())
        cfg.seed = std::strtoull(it->second.c_str(), nullptr, 10);
      return make_simulated_spacemouse(cfg);
    }
    if (spec.params.count("seed"))
      return fail(Errc::invalid_argument, spec.text + ": seed applies to spacemouse:sim only");
    devices::HidSpaceMouseOptions o;
    o.path = spec.target;
    o.vendor_id = *vid;
    o.product_id = *pid;
    return devices::make_hid_spacemouse_source(o);
  }
  return fail(Errc::invalid_argument,
              spec.text + ": '" + spec.scheme + "' is not a 6-DOF input device (spaceball, magellan, spacemouse)");
}

}  // namespace mimic::sim
