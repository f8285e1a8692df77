#include <algorithm>
#include <cmath>
#include <cstring>

#include "flock_bus.h"

namespace mimic::sim::detail {

namespace fl = devices::flock;

std::vector<uint8_t> FlockBus::examine_reply(Unit& u, uint8_t p) {
  const int size = fl::examine_size(p);
  if (size == 0) {
    set_error(u.address, 6);
    return {};
  }
  std::vector<uint8_t> r(static_cast<size_t>(size), 0);
  auto word = [&](int v) { fl::put_le16(static_cast<int16_t>(static_cast<uint16_t>(v)), r.data()); };
  switch (p) {
    case fl::param::kStatus: {
      fl::BirdStatus s;
      s.master = u.address == master;
      s.initialized = configured;
      s.error_pending = u.error_code != 0;
      s.running = !sleeping && ((running_mask >> u.address) & 1u);
      s.sleeping = sleeping;
      s.format = u.format;
      s.streaming = streaming && (group_mode || stream_address == u.address);
      word(fl::encode_status(s));
      break;
    }
    case fl::param::kSoftwareRevision: word(cfg.software_revision); break;
    case fl::param::kCrystalSpeed: word(static_cast<int>(std::lround(cfg.crystal_mhz))); break;
    case fl::param::kPositionScaling: word(u.position_scaling); break;
    case fl::param::kMeasurementRateCount: word(rate_count); break;
    case fl::param::kMeasurementRate: word(static_cast<int>(std::lround(rate_hz() * 256))); break;
    case fl::param::kErrorCode:
      r[0] = static_cast<uint8_t>(u.error_code);
      u.error_code = 0;  // reading the error clears it
      break;
    case fl::param::kSystemModel: std::memcpy(r.data(), u.erc ? "6DERC     " : "6DFOB     ", 10); break;
    case fl::param::kExpandedErrorCode:
      r[0] = static_cast<uint8_t>(u.error_code);
      r[1] = static_cast<uint8_t>(u.error_extra);
      u.error_code = 0;
      break;
    case fl::param::kAddressingMode: r[0] = 0; break;
    case fl::param::kFbbAddress: r[0] = static_cast<uint8_t>(u.address); break;
    case fl::param::kHemisphere: {
      const auto h = fl::hemisphere_bytes(u.hemisphere);
      r[0] = h[0];
      r[1] = h[1];
      break;
    }
    case 25:
    case 26:
    case 27: word(1000 + 10 * u.address + (p - 25)); break;
    case fl::param::kGroupMode: r[0] = group_mode ? 1 : 0; break;
    case fl::param::kFlockStatus:
      for (int a = 1; a <= 14; ++a) {
        if (standalone || !unit_exists(a)) continue;
        const Unit& x = units[static_cast<size_t>(a)];
        uint8_t b = fl::kUnitAccessible;
        if ((running_mask >> a) & 1u) b |= fl::kUnitRunning;
        if (x.sensor) b |= fl::kUnitSensor;
        if (x.erc) b |= fl::kUnitErc;
        if (x.transmitter) b |= fl::kUnitTransmitter;
        r[static_cast<size_t>(a - 1)] = b;
      }
      break;
    case fl::param::kAutoConfig:
      r[0] = standalone ? 0 : 1;
      r[1] = static_cast<uint8_t>(running_mask & 0xFF);
      r[2] = static_cast<uint8_t>((running_mask >> 8) & 0xFF);
      break;
    default:
      if (auto it = u.params.find(p); it != u.params.end())
        std::copy_n(it->second.begin(), std::min(it->second.size(), r.size()), r.begin());
      break;
  }
  return r;
}

void FlockBus::change(Unit& u, uint8_t p, std::span<const uint8_t> data, double now) {
  switch (p) {
    case fl::param::kPositionScaling: u.position_scaling = fl::get_le16(data.data()); return;
    case fl::param::kMeasurementRateCount: rate_count = std::max<int>(1, fl::get_le16(data.data())); return;
    case fl::param::kMeasurementRate: {
      const double hz = static_cast<uint16_t>(fl::get_le16(data.data())) / 256.0;
      if (hz >= 14 && hz <= 144) rate_count = fl::measurement_rate_count(hz, cfg.crystal_mhz);
      return;
    }
    case fl::param::kHemisphere:
      if (auto h = fl::hemisphere_from_bytes(data[0], data[1])) u.hemisphere = *h;
      return;
    case fl::param::kGroupMode: group_mode = data[0] != 0; return;
    case fl::param::kAutoConfig: {
      const int n = data[0];
      streaming = false;
      busy_until_s = now + cfg.auto_config_busy_s;
      if (standalone) {
        set_error(master, 7);  // a standalone unit is not an FBB master
        return;
      }
      const int present = static_cast<int>(units.size()) - 1;
      if (n < 1 || n > present) {
        configured = false;
        running_mask = 0;
        set_error(master, 13, std::min(n, present + 1));
        return;
      }
      configured = true;
      sleeping = false;  // auto-configuration wakes a sleeping flock
      running_mask = 0;
      for (int a = 1; a <= n; ++a) running_mask |= 1u << a;
      return;
    }
    default: u.params[p].assign(data.begin(), data.end()); return;
  }
}

}  // namespace mimic::sim::detail
