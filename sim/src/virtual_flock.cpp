#include "mimic/sim/virtual_flock.h"

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <cstring>
#include <deque>
#include <map>
#include <mutex>
#include <random>
#include <thread>
#include <vector>

#include "mimic/devices/flock_packet.h"
#include "flock_bus.h"
#include "mimic/core/clock.h"
#include "mimic/core/thread_priority.h"
#include "mimic/sim/pty.h"

namespace mimic::sim {

namespace fl = devices::flock;
using detail::Unit;

namespace {

struct Output {
  double due_s;  // sim time the last byte leaves the UART
  std::vector<uint8_t> bytes;
  int address;  // bird address for records, -1 for replies and garbage
};

enum class Fault { tear, phase, drop };

}  // namespace

struct VirtualFlock::Impl : detail::FlockBus {
  Pty pty;
  std::thread thread;
  std::atomic<bool> stop{false};
  double t0_s = 0;  // steady_now_s() at start

  // Hooks and stats, shared with other threads.
  mutable std::mutex mu;
  bool reset_requested = false;
  double silent_for_s = 0;
  size_t garbage_requested = 0;
  std::deque<Fault> faults;
  VirtualFlockStats stats;

  // Device state, owned by the simulator thread.
  bool xoff = false;
  int report_divisor = 1;
  double silent_until_s = -1;
  int pending_prefix = -1;
  bool answered_once = false;  // an EXAMINE was answered since the start
  std::vector<uint8_t> cmd;
  double next_tick_s = 0;
  uint64_t tick_index = 0;
  double line_free_s = 0;
  std::deque<Output> out;
  std::mt19937_64 rng;
  bool host_present = false;
  bool line_mismatch = false;

  double now_s() const { return steady_now_s() - t0_s; }
  double byte_time_s() const { return cfg.pace_output ? 10.0 / cfg.baud : 0.0; }

  void power_up() {
    const int count = cfg.birds + (cfg.erc ? 1 : 0);
    standalone = count == 1;
    master = standalone ? 0 : 1;
    units.assign(standalone ? 1 : static_cast<size_t>(count) + 1, Unit{});
    for (size_t a = 0; a < units.size(); ++a) {
      Unit& u = units[a];
      u.address = static_cast<int>(a);
      u.erc = cfg.erc && a == 1;
      u.sensor = !u.erc && (standalone || a >= 1);
      u.transmitter = (static_cast<int>(a) == master) || u.erc;
      u.params[9] = {','};
      u.params[32] = {20, 0};  // FBB host delay 200 us
    }
    if (!standalone) units[0].sensor = false;  // address 0 is not a unit in a flock
    configured = standalone;
    running_mask = standalone ? 1u : 0u;
    group_mode = false;
    streaming = false;
    sleeping = false;
    xoff = false;
    report_divisor = 1;
    rate_count = fl::measurement_rate_count(cfg.measurement_rate_hz, cfg.crystal_mhz);
    pending_prefix = -1;
    cmd.clear();
    out.clear();
  }

  std::vector<int> sensor_addresses() const {
    std::vector<int> v;
    for (const Unit& u : units)
      if (u.sensor && unit_exists(u.address)) v.push_back(u.address);
    return v;
  }
  fl::PositionRange range_of(const Unit& u) const {
    if (cfg.erc) return fl::PositionRange::in144;
    return u.position_scaling == 1 ? fl::PositionRange::in72 : fl::PositionRange::in36;
  }

  // ------------------------------------------------------------------------------------------
  // Output

  void queue(double start_s, std::vector<uint8_t> bytes, int address) {
    const double begin = std::max(start_s, line_free_s);
    const double due = begin + static_cast<double>(bytes.size()) * byte_time_s();
    line_free_s = due;
    out.push_back(Output{due, std::move(bytes), address});
  }

  std::vector<uint8_t> make_record(double t_s, int address) {
    Unit& u = units[static_cast<size_t>(address)];
    const auto addrs = sensor_addresses();
    const int bird = static_cast<int>(std::find(addrs.begin(), addrs.end(), address) - addrs.begin());
    devices::SensorSample s;
    s.sensor = static_cast<uint16_t>(address);
    cfg.provider(t_s, bird, s);
    fl::Measurement m = fl::measurement_from_sample(s);
    // A magnetic tracker cannot tell a position from its mirror image: it reports the one in
    // the selected hemisphere.
    const bool mirrored = !fl::in_hemisphere(u.hemisphere, m.position_in);
    if (mirrored) m.position_in = -m.position_in;
    // Beyond full scale the position words pin at their limit (to_raw saturates them).
    const double full_scale = fl::full_scale_in(range_of(u)) * (32764.0 / 32768.0);
    const bool saturated = std::abs(m.position_in.x) > full_scale || std::abs(m.position_in.y) > full_scale ||
                           std::abs(m.position_in.z) > full_scale;
    m.address = static_cast<uint8_t>(address);
    m.button = u.button_mode ? static_cast<uint8_t>(s.buttons & 0x70) : 0;
    const fl::RecordLayout layout{u.format, u.button_mode, group_mode && !standalone};
    const fl::RawRecord raw = fl::to_raw(m, layout, range_of(u));
    std::vector<uint8_t> bytes(layout.size());
    fl::encode_record(raw, bytes);
    apply_faults(bytes);
    std::lock_guard lock(mu);
    ++stats.records_sent;
    if (saturated) ++stats.saturated_records;
    if (mirrored) ++stats.mirrored_records;
    return bytes;
  }

  void apply_faults(std::vector<uint8_t>& r) {
    std::optional<Fault> f;
    {
      std::lock_guard lock(mu);
      if (!faults.empty()) {
        f = faults.front();
        faults.pop_front();
      }
    }
    if (!f && cfg.fault_rate > 0 && std::uniform_real_distribution<double>(0, 1)(rng) < cfg.fault_rate)
      f = static_cast<Fault>(rng() % 3);
    if (!f || r.size() < 3) return;
    switch (*f) {
      case Fault::tear: r.resize(r.size() / 2); break;
      case Fault::phase: r[1 + rng() % (r.size() - 2)] |= 0x80; break;
      case Fault::drop: r.erase(r.begin() + 1 + static_cast<long>(rng() % (r.size() - 1))); break;
    }
    std::lock_guard lock(mu);
    ++stats.faults_injected;
  }

  std::vector<uint8_t> garbage(size_t n) {
    std::vector<uint8_t> g(n);
    for (auto& b : g) b = static_cast<uint8_t>(rng() & (rng() % 4 == 0 ? 0xFF : 0x7F));
    return g;
  }

  void boot_noise(double t) {
    if (!cfg.boot_garbage) return;
    auto g = garbage(2 + rng() % 6);
    // ... and the head of a stale point record.
    const auto addrs = sensor_addresses();
    if (!addrs.empty()) {
      auto r = make_record(t, addrs.front());
      g.insert(g.end(), r.begin(), r.begin() + static_cast<long>(1 + rng() % (r.size() - 1)));
    }
    queue(t, std::move(g), -1);
  }

  void emit_point(double t, int target) {
    if (group_mode && !standalone) {
      for (int a : sensor_addresses())
        if ((running_mask >> a) & 1u) queue(t, make_record(t, a), a);
    } else if (unit_exists(target) && units[static_cast<size_t>(target)].sensor) {
      queue(t, make_record(t, target), target);
    }
  }

  void stream_ticks(double now) {
    const double period = 1.0 / rate_hz();
    while (next_tick_s <= now) {
      const double t = next_tick_s;
      ++tick_index;
      next_tick_s = t + period;
      if (!streaming || sleeping || tick_index % static_cast<uint64_t>(report_divisor) != 0) continue;
      // The unit's output buffer holds about one cycle; a slower line drops whole cycles.
      if (line_free_s > t + period) continue;
      emit_point(t, stream_address);
    }
  }

  void flush_output(double now) {
    while (!out.empty() && !xoff && out.front().due_s <= now) {
      Output o = std::move(out.front());
      out.pop_front();
      if (now < silent_until_s) continue;  // nobody on the wire
      auto w = pty.write(o.bytes);
      if (!w) {
        host_present = false;
        continue;
      }
      if (cfg.on_bytes && *w > 0) cfg.on_bytes(steady_now_s(), true, std::span<const uint8_t>(o.bytes.data(), *w));
      if (o.address >= 0 && cfg.on_record_written) cfg.on_record_written(steady_now_s(), o.address, o.bytes);
    }
  }

  // ------------------------------------------------------------------------------------------
  // Commands

  // Total length of the command in `cmd` (first byte known), 0 while a parameter byte that
  // decides it is still missing, -1 for an invalid command byte.
  int command_length() const {
    const uint8_t c = cmd[0];
    if (fl::fbb_prefix_address(c) >= 0) return 1;
    switch (c) {
      case 0xA0: return 2;
      case '@':
      case 'B':
      case '?':
      case 'F':
      case 'G':
      case 'N':
      case '/':
      case 'Q':
      case 'R':
      case 'S':
      case 'T':
      case fl::cmd::kXon:
      case fl::cmd::kXoff: return 1;
      case 'O':
      case 'M':
      case 'A':
      case '0': return 2;
      case 'L': return 3;
      case 'H':
      case 'J': return 13;
      case 'r':
      case 'q': return 7;
      case 'P': {
        if (cmd.size() < 2) return 0;
        const int n = fl::change_size(cmd[1]);
        return n > 0 ? 2 + n : -1;
      }
      default: return fl::format_from_command(c) ? 1 : -1;
    }
  }

  void on_byte(uint8_t b, double now) {
    if (now < busy_until_s) {
      std::lock_guard lock(mu);
      ++stats.dropped_while_busy;
      return;
    }
    cmd.push_back(b);
    const int len = command_length();
    if (len < 0) {
      const int target = pending_prefix >= 0 ? pending_prefix : master;
      set_error(target, 6);
      pending_prefix = -1;
      cmd.clear();
      std::lock_guard lock(mu);
      ++stats.invalid_commands;
      return;
    }
    if (len == 0 || static_cast<int>(cmd.size()) < len) return;
    execute(now);
    cmd.clear();
  }

  void execute(double now) {
    const uint8_t c = cmd[0];
    if (const int a = fl::fbb_prefix_address(c); a >= 0) {
      pending_prefix = a;
      return;
    }
    if (c == 0xA0) {
      pending_prefix = cmd[1];
      return;
    }
    {
      std::lock_guard lock(mu);
      ++stats.commands;
    }
    int target = master;
    if (pending_prefix >= 0) {
      target = pending_prefix;
      pending_prefix = -1;
      if (!unit_exists(target)) {
        set_error(master, 13, target);  // nobody answers on the bus
        return;
      }
    }
    Unit& u = units[static_cast<size_t>(target)];
    const double reply_at = now + cfg.reply_delay_s;
    const bool ready = configured && ((running_mask >> target) & 1u);

    if (auto f = fl::format_from_command(c)) {
      u.format = *f;
      return;
    }
    switch (c) {
      case '@':
        if (!ready) {
          set_error(target, configured ? 9 : 8);
          return;
        }
        streaming = true;
        stream_address = target;
        next_tick_s = now;
        return;
      case 'B':
        streaming = false;
        // Drivers send B first of all to stop a stream; an unconfigured flock just stays quiet.
        if (!ready) return;
        if (!sleeping) emit_point(reply_at, target);
        return;
      case '?': streaming = false; return;
      case 'F': sleeping = false; return;
      case 'G':
        sleeping = true;
        streaming = false;
        return;
      case fl::cmd::kXon: xoff = false; return;
      case fl::cmd::kXoff: xoff = true; return;
      case 'Q':
      case 'R':
      case 'S':
      case 'T': report_divisor = fl::report_rate_divisor(c); return;
      case '/':
        configured = standalone;
        running_mask = standalone ? 1u : 0u;
        group_mode = false;
        streaming = false;
        return;
      case 'N': queue(reply_at, {static_cast<uint8_t>(0)}, -1); return;
      case 'M': u.button_mode = cmd[1] != 0; return;
      case 'L':
        if (auto h = fl::hemisphere_from_bytes(cmd[1], cmd[2]))
          u.hemisphere = *h;
        else
          set_error(target, 6);
        return;
      case 'O': examine(u, cmd[1], reply_at); return;
      case 'P': change(u, cmd[1], std::span<const uint8_t>(cmd).subspan(2), now); return;
      case 'r': u.params[24].assign(cmd.begin() + 1, cmd.end()); return;
      case 'q': u.params[23].assign(cmd.begin() + 1, cmd.end()); return;
      default: return;  // H, J, A, 0: accepted, no effect on the simulated field
    }
  }

  void examine(Unit& u, uint8_t p, double reply_at) {
    // The first answer after power-up may be late (a slow adapter): the host must not read the
    // next answer one behind.
    if (!answered_once && cfg.first_reply_delay_s > cfg.reply_delay_s)
      reply_at += cfg.first_reply_delay_s - cfg.reply_delay_s;
    answered_once = true;
    if (std::vector<uint8_t> r = examine_reply(u, p); !r.empty()) queue(reply_at, std::move(r), -1);
  }

  // ------------------------------------------------------------------------------------------

  void take_hooks(double now) {
    bool do_reset = false;
    double silence = 0;
    size_t garbage_n = 0;
    {
      std::lock_guard lock(mu);
      std::swap(do_reset, reset_requested);
      std::swap(silence, silent_for_s);
      std::swap(garbage_n, garbage_requested);
    }
    if (do_reset) {
      power_up();
      line_free_s = now;
      boot_noise(now);
    }
    if (silence > 0) silent_until_s = now + silence;
    if (garbage_n > 0) queue(now, garbage(garbage_n), -1);
  }

  void publish_state() {
    std::lock_guard lock(mu);
    stats.streaming = streaming;
    stats.group_mode = group_mode;
    stats.configured = configured;
    stats.sleeping = sleeping;
  }

  void check_line() {
    const LineSettings s = pty.line_settings();
    const bool bad = s.baud != cfg.baud || s.data_bits != 8 || s.parity || s.stop_bits != 1 || s.rtscts;
    if (bad && !line_mismatch) {
      std::lock_guard lock(mu);
      ++stats.line_mismatches;
    }
    line_mismatch = bad;
  }

  void run() {
    std::array<uint8_t, 512> buf{};
    while (!stop.load(std::memory_order_relaxed)) {
      double now = now_s();
      take_hooks(now);
      stream_ticks(now);
      flush_output(now);
      publish_state();

      double wake = now + 0.01;
      if (streaming) wake = std::min(wake, next_tick_s);
      if (!out.empty() && !xoff) wake = std::min(wake, out.front().due_s);
      const auto timeout = std::chrono::microseconds(static_cast<int64_t>(std::max(0.0, wake - now_s()) * 1e6));
      switch (pty.wait_readable(timeout)) {
        case Pty::Wait::readable: {
          if (!host_present) {
            host_present = true;
            std::lock_guard lock(mu);
            ++stats.host_opens;
          }
          auto n = pty.read(buf);
          if (!n) break;
          now = now_s();
          if (now < silent_until_s) break;  // the cable is out: bytes go nowhere
          check_line();
          if (cfg.on_bytes && *n > 0) cfg.on_bytes(steady_now_s(), false, std::span<const uint8_t>(buf.data(), *n));
          for (size_t i = 0; i < *n; ++i) on_byte(buf[i], now);
          break;
        }
        case Pty::Wait::no_peer:
          host_present = false;
          std::this_thread::sleep_for(std::min(timeout, std::chrono::microseconds(2000)));
          break;
        case Pty::Wait::timeout: break;
      }
    }
  }
};

VirtualFlock::VirtualFlock(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}

VirtualFlock::~VirtualFlock() { stop(); }

Result<std::unique_ptr<VirtualFlock>> VirtualFlock::create(VirtualFlockConfig config) {
  if (config.birds < 1 || config.birds + (config.erc ? 1 : 0) > 14)
    return fail(Errc::invalid_argument, "virtual flock: birds must be 1..14 (13 with an ERC)");
  if (!fl::report_rate_command(1) || config.baud <= 0)
    return fail(Errc::invalid_argument, "virtual flock: bad baud rate");
  if (config.measurement_rate_hz < 14 || config.measurement_rate_hz > 144)
    return fail(Errc::out_of_range, "virtual flock: measurement rate must be 14..144 Hz");
  auto pty = Pty::open();
  if (!pty) return tl::unexpected(pty.error());
  auto impl = std::make_unique<Impl>();
  if (!config.provider) config.provider = make_builtin_flock_motion(config.seed);
  impl->cfg = std::move(config);
  impl->pty = std::move(*pty);
  impl->rng.seed(impl->cfg.seed);
  impl->power_up();
  return std::unique_ptr<VirtualFlock>(new VirtualFlock(std::move(impl)));
}

const std::string& VirtualFlock::slave_path() const { return impl_->pty.slave_path(); }

Status VirtualFlock::start() {
  if (impl_->thread.joinable()) return fail(Errc::invalid_argument, "virtual flock already started");
  impl_->stop = false;
  impl_->t0_s = steady_now_s();
  impl_->thread = std::thread([this] {
    if (impl_->cfg.realtime_priority > 0) set_thread_fifo(std::clamp(impl_->cfg.realtime_priority, 1, 99));
    impl_->run();
  });
  return {};
}

void VirtualFlock::stop() {
  if (!impl_ || !impl_->thread.joinable()) return;
  impl_->stop = true;
  impl_->thread.join();
}

void VirtualFlock::reset() {
  std::lock_guard lock(impl_->mu);
  impl_->reset_requested = true;
}

void VirtualFlock::go_silent(std::chrono::milliseconds duration) {
  std::lock_guard lock(impl_->mu);
  impl_->silent_for_s = std::chrono::duration<double>(duration).count();
}

void VirtualFlock::inject_garbage(size_t bytes) {
  std::lock_guard lock(impl_->mu);
  impl_->garbage_requested += bytes;
}

void VirtualFlock::tear_next_record() {
  std::lock_guard lock(impl_->mu);
  impl_->faults.push_back(Fault::tear);
}

void VirtualFlock::phase_error_next_record() {
  std::lock_guard lock(impl_->mu);
  impl_->faults.push_back(Fault::phase);
}

void VirtualFlock::drop_byte_next_record() {
  std::lock_guard lock(impl_->mu);
  impl_->faults.push_back(Fault::drop);
}

VirtualFlockStats VirtualFlock::stats() const {
  std::lock_guard lock(impl_->mu);
  return impl_->stats;
}

}  // namespace mimic::sim
