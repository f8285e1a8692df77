#include "mimic/sim/virtual_spaceball.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>

namespace mimic::sim {

namespace sb = devices::spaceball;

namespace {

// Buttons a model can report at all, in InputFrame bits.
uint32_t button_mask(sb::Model m) {
  switch (m) {
    case sb::Model::sb3003: return 0x83u;      // left, right, rezero
    case sb::Model::sb4000flx: return 0xFFFu;  // 12 buttons
    default: return 0x1FFu;                    // 2003: 8 buttons and the pick button
  }
}

const char* firmware_date(sb::Model m) {
  switch (m) {
    case sb::Model::sb3003: return "11-Jan-1994";
    case sb::Model::sb4000flx: return "24-Oct-1997";
    default: return "02-Mar-1993";
  }
}

}  // namespace

std::string default_spaceball_firmware(sb::Model model) {
  switch (model) {
    case sb::Model::sb3003: return "2.63";
    case sb::Model::sb4000flx: return "2.43";
    default: return "2.15";
  }
}

Result<sb::Model> parse_spaceball_model(std::string_view name) {
  if (name == "4000flx" || name == "4000" || name == "4000FLX") return sb::Model::sb4000flx;
  if (name == "3003") return sb::Model::sb3003;
  if (name == "2003") return sb::Model::sb2003;
  return fail(Errc::invalid_argument,
              "unknown Spaceball model '" + std::string(name) + "' (expected 4000flx, 3003 or 2003)");
}

SpaceballDevice::SpaceballDevice(VirtualSpaceballConfig config)
    : SerialDevice(config.baud, 10), cfg_(std::move(config)), fault_rng_(cfg_.seed ^ 0x5B5B5B5B5B5B5B5Bull) {
  if (cfg_.model == sb::Model::unknown) cfg_.model = sb::Model::sb2003;
  firmware_ = cfg_.firmware.empty() ? default_spaceball_firmware(cfg_.model) : cfg_.firmware;
  if (!cfg_.input) cfg_.input = default_input_pattern(cfg_.seed);
  // Already plugged in: it powered up long before, and its banner went to a closed port.
  if (!cfg_.power_up_on_open) {
    power_up(0.0);
    banner_pending_ = false;
  }
}

void SpaceballDevice::power_up(double now_s) {
  // Power-up: the firmware zeroes the ball, waits, then announces itself.
  enabled_ = false;
  line_.clear();
  banner_pending_ = true;
  banner_at_s_ = now_s + cfg_.power_up_delay_s;
  banner_word_ = "poweron";
  power_on_s_ = now_s;
  buttons_ = 0;
}

void SpaceballDevice::host_opened(double now_s) {
  if (cfg_.power_up_on_open) return power_up(now_s);
  // A device that stays plugged in keeps running between opens: a banner that fell due while
  // nobody had the port open (after a reset) was lost on the line.
  line_.clear();
  if (banner_pending_ && banner_at_s_ < now_s) banner_pending_ = false;
}

void SpaceballDevice::receive(std::span<const uint8_t> bytes, double now_s) {
  if (muted()) return;
  for (uint8_t b : bytes) {
    if (b == 0x11 || b == 0x13 || b == 0x0A) continue;
    if (b == 0x0D) {
      // While the firmware boots (until the banner) the host is not listened to.
      if (!line_.empty() && !banner_pending_) command(line_, now_s);
      line_.clear();
      continue;
    }
    if (line_.size() < 64) line_.push_back(static_cast<char>(b));
  }
}

void SpaceballDevice::banner(const char* word, double at_s) {
  char text[160];
  const int n = std::snprintf(text, sizeof text,
                              "\x11\r@1 Spaceball alive and well after a %s reset.\r\n"
                              "@2 Firmware version %s created on %s.\r",
                              word, firmware_.c_str(), firmware_date(cfg_.model));
  send(std::string_view(text, static_cast<size_t>(n)), at_s);
}

void SpaceballDevice::reply(std::span<const uint8_t> body, double at_s) {
  std::array<uint8_t, 2 * 80 + 1> wire{};
  const size_t n = sb::encode_packet(body, wire);
  send(std::span<const uint8_t>(wire.data(), n), at_s);
}

void SpaceballDevice::reply(std::string_view text, double at_s) {
  reply(std::span<const uint8_t>(reinterpret_cast<const uint8_t*>(text.data()), text.size()), at_s);
}

void SpaceballDevice::send_keys(uint32_t buttons, double at_s) {
  if (cfg_.model == sb::Model::sb4000flx) reply(sb::advanced_keys_body(buttons, cfg_.right_handed, true), at_s);
  reply(sb::keys_body(cfg_.model, buttons, true), at_s);
}

void SpaceballDevice::command(std::string_view cmd, double now_s) {
  const double at = now_s + cfg_.reply_delay_s;
  const bool flx = cfg_.model == sb::Model::sb4000flx;
  auto unknown = [&] {
    std::string r(1, '?');
    r.append(cmd);
    reply(r, at);
  };
  switch (cmd[0]) {
    case '@':
      enabled_ = false;
      banner_pending_ = true;
      banner_at_s_ = now_s + cfg_.reset_delay_s;
      banner_word_ = "software";
      ++resets_;
      return;
    case 'h':
      if (cmd != "hm") return unknown();
      if (flx) {
        reply("HvFirmware version " + firmware_ + " created on " + firmware_date(cfg_.model), at);
      } else {
        reply(cfg_.model == sb::Model::sb3003 ? "Hm3003C" : "Hm2003C", at);
      }
      return;
    case '"':
      if (!flx) return unknown();
      reply("\"1 Spaceball 4000 FLX", at);
      reply(std::string("\"2 B:12 ") + (cfg_.right_handed ? "R" : "L") + " PnP:p Az:a Sns:S", at);
      reply("\"3 V" + firmware_ + " created on " + firmware_date(cfg_.model), at);
      reply("\"4 Copyright(C) 1997 Spacetec IMC Corporation", at);
      return;
    case 'k': send_keys(buttons_, at); return;
    case '%': reply(cmd, at); return;
    case 'M':
      // 2003/3003: MSS… enables ball data and a bare M disables it; the 4000 FLX enables on M.
      enabled_ = flx || cmd.substr(0, 3) == "MSS";
      if (enabled_) {
        next_data_s_ = at;
        at_rest_sent_ = false;
        last_data_s_ = -1;
      }
      reply(cmd, at);
      return;
    case '-':
      if (!flx) return unknown();
      enabled_ = false;
      reply(cmd, at);
      return;
    case 'C':
    case 'N':
    case 'F':
    case 'P':
    case 'Z': reply(cmd, at); return;
    case 'Y':
      if (!flx || (cmd != "YS" && cmd != "YC")) return unknown();
      reply(cmd, at);
      return;
    case 'A':
      if (!flx) return unknown();
      // Auto-rezero: period 1000 ms and window 20 unless set with A + 4 + 2 hex digits.
      if (cmd == "AE" || cmd == "AD") {
        reply(std::string("a03E814") + cmd[1], at);
      } else if (cmd.size() == 7) {
        std::string r(1, 'a');
        r.append(cmd.substr(1));
        r.push_back('E');
        reply(r, at);
      } else {
        unknown();
      }
      return;
    case 'S':
      if (!flx) return unknown();
      return;          // a beep; nothing comes back
    case 'B': return;  // beep pattern
    default: unknown();
  }
}

void SpaceballDevice::advance(double now_s) {
  if (muted()) return;
  if (banner_pending_ && now_s >= banner_at_s_) {
    banner_pending_ = false;
    banner(banner_word_, banner_at_s_);
  }
  const double t = now_s - power_on_s_;
  const devices::InputFrame f = cfg_.input(t);
  // Keys report on change once the firmware is up (the banner has gone out).
  if (!banner_pending_) {
    const uint32_t b = f.buttons & button_mask(cfg_.model);
    if (b != buttons_) {
      buttons_ = b;
      send_keys(b, now_s);
    }
  }
  if (!enabled_ || now_s < next_data_s_) return;
  const sb::Axes axes = sb::from_frame(f, cfg_.scaling);
  const bool rest = std::all_of(axes.begin(), axes.end(), [](int16_t v) { return v == 0; });
  next_data_s_ = std::max(next_data_s_ + cfg_.data_period_s, now_s);
  if (rest && at_rest_sent_) return;  // a ball at rest goes quiet after one zero packet
  at_rest_sent_ = rest;
  const double dt = last_data_s_ < 0 ? cfg_.data_period_s : now_s - last_data_s_;
  last_data_s_ = now_s;
  const auto period = static_cast<uint16_t>(std::clamp(std::lround(dt * 16000.0), 0L, 65535L));
  send_displacement(axes, period, now_s);
  ++d_packets_;
}

void SpaceballDevice::send_displacement(const sb::Axes& axes, uint16_t period, double at_s) {
  std::array<uint8_t, 2 * 15 + 1 + 2> wire{};  // worst-case escaping, CR, and room for `^X`
  size_t n = sb::encode_packet(sb::displacement_body(period, axes), wire);
  const double roll = static_cast<double>(fault_rng_() >> 11) * (1.0 / 9007199254740992.0);
  if (roll >= cfg_.fault_rate) {
    send(std::span<const uint8_t>(wire.data(), n), at_s);
    return;
  }
  ++faults_;
  switch (fault_rng_() % 3) {
    case 0: {  // noise, ended by a CR so it stands as a packet of its own
      std::array<uint8_t, 8> noise{};
      const size_t k = 1 + fault_rng_() % 6;
      for (size_t i = 0; i < k; ++i) noise[i] = static_cast<uint8_t>(0x80 | (fault_rng_() & 0x7F));
      noise[k] = 0x0D;
      send(std::span<const uint8_t>(noise.data(), k + 1), at_s);
      send(std::span<const uint8_t>(wire.data(), n), at_s);
      return;
    }
    case 1: {  // a lost byte (never half of an escape pair, which would re-pair silently)
      for (int tries = 0; tries < 8; ++tries) {
        const size_t i = 1 + fault_rng_() % (n - 2);
        if (wire[i] == 0x5E || wire[i - 1] == 0x5E) continue;
        std::copy(wire.begin() + static_cast<long>(i) + 1, wire.begin() + static_cast<long>(n),
                  wire.begin() + static_cast<long>(i));
        --n;
        break;
      }
      send(std::span<const uint8_t>(wire.data(), n), at_s);
      return;
    }
    default: {  // `^X` is no escape
      const size_t i = 1 + fault_rng_() % (n - 1);
      std::copy_backward(wire.begin() + static_cast<long>(i), wire.begin() + static_cast<long>(n),
                         wire.begin() + static_cast<long>(n) + 2);
      wire[i] = 0x5E;
      wire[i + 1] = 'X';
      n += 2;
      send(std::span<const uint8_t>(wire.data(), n), at_s);
      return;
    }
  }
}

Result<std::unique_ptr<PtyServer>> start_virtual_spaceball(VirtualSpaceballConfig config, const std::string& log_path) {
  return PtyServer::start(std::make_unique<SpaceballDevice>(std::move(config)), log_path);
}

}  // namespace mimic::sim
