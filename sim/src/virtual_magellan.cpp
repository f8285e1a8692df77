#include "mimic/sim/virtual_magellan.h"

#include <array>

namespace mimic::sim {

namespace mg = devices::magellan;

MagellanDevice::MagellanDevice(VirtualMagellanConfig config) : SerialDevice(config.baud, 11), cfg_(std::move(config)) {
  expect_line({9600, 2, 2, true});
  if (!cfg_.input) cfg_.input = default_input_pattern(cfg_.seed);
}

void MagellanDevice::host_opened(double now_s) {
  line_.clear();
  mode_ = 0;
  power_on_s_ = now_s;
  sent_any_ = false;
  buttons_ = 0;
}

void MagellanDevice::receive(std::span<const uint8_t> bytes, double now_s) {
  if (muted()) return;
  for (uint8_t b : bytes) {
    if (b == 0x0D) {
      if (!line_.empty()) command(line_, now_s);
      line_.clear();
    } else if (b != 0x0A && line_.size() < 64) {
      line_.push_back(static_cast<char>(b));
    }
  }
}

void MagellanDevice::command(const std::string& cmd, double now_s) {
  const double at = now_s + cfg_.reply_delay_s;
  auto echo = [&](const std::string& s) { send(s + "\r", at); };
  auto nibbles_ok = [&](size_t count) {
    if (cmd.size() != 1 + count) return false;
    for (size_t i = 1; i < cmd.size(); ++i) {
      if (!mg::valid_nibble_char(static_cast<uint8_t>(cmd[i])) && cmd[i] != '?') return false;
    }
    return true;
  };
  switch (cmd[0]) {
    case '@': return;  // a Spaceball reset probe: a Magellan stays silent so the host tries Magellan next
    case 'v':
      if (cmd == "vQ") return echo("v" + cfg_.version);
      break;
    case 'z':
      if (cmd == "z") return echo("z");
      break;
    case 'b':
      if (cmd.size() <= 2) return echo("b");  // the beep echo drops its argument
      break;
    case 'm':
      if (nibbles_ok(1)) {
        mode_ = static_cast<unsigned>(cmd[1]) & 0xFu;
        sent_any_ = false;
        next_data_s_ = at;
        return echo(cmd);
      }
      break;
    case 'n':
      if (nibbles_ok(1)) return echo(cmd);
      break;
    case 'c':
    case 'q':
    case 'p':
      if (nibbles_ok(2)) return echo(cmd);
      break;
    default: break;
  }
  std::string err = "e1";
  err.append(cmd.substr(0, 2));
  echo(err);
}

void MagellanDevice::advance(double now_s) {
  if (muted()) return;
  const devices::InputFrame f = cfg_.input(now_s - power_on_s_);
  const uint32_t b = f.buttons & 0x7FFu;
  if (b != buttons_) {
    buttons_ = b;
    std::array<uint8_t, 6> k{};
    const size_t n = mg::keys_packet(b, k);
    send(std::span<const uint8_t>(k.data(), n), now_s);
  }
  if (mode_ == 0 || now_s < next_data_s_) return;
  next_data_s_ = std::max(next_data_s_ + cfg_.data_period_s, now_s);
  mg::Axes axes = mg::from_frame(f, cfg_.scaling);
  if (!(mode_ & 2u)) axes[0] = axes[1] = axes[2] = 0;  // translation off
  if (!(mode_ & 1u)) axes[3] = axes[4] = axes[5] = 0;  // rotation off
  if (sent_any_ && axes == last_sent_) return;
  sent_any_ = true;
  last_sent_ = axes;
  const auto d = mg::data_packet(axes);
  send(std::span<const uint8_t>(d.data(), d.size()), now_s);
}

Result<std::unique_ptr<PtyServer>> start_virtual_magellan(VirtualMagellanConfig config, const std::string& log_path) {
  return PtyServer::start(std::make_unique<MagellanDevice>(std::move(config)), log_path);
}

}  // namespace mimic::sim
