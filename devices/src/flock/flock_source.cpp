#include "mimic/devices/flock.h"

#include <pthread.h>
#include <sched.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <condition_variable>
#include <cstdio>
#include <mutex>
#include <optional>
#include <thread>

#include "flock/spsc_queue.h"
#include "mimic/core/thread_priority.h"
#include "mimic/devices/serial.h"

namespace mimic::devices {

namespace fl = flock;
using Clock = std::chrono::steady_clock;
using std::chrono::milliseconds;

namespace {

double seconds_of(Clock::time_point t) { return std::chrono::duration<double>(t.time_since_epoch()).count(); }

bool parse_bool(const std::string& v) { return v == "1" || v == "true" || v == "yes" || v == "on"; }

std::string hex2(unsigned v) {
  char b[8];
  std::snprintf(b, sizeof b, "%02Xh", v & 0xFFu);
  return b;
}

}  // namespace

Result<FlockConfig> flock_config_from_spec(const SourceSpec& spec) {
  if (spec.scheme != "flock") return fail(Errc::invalid_argument, "not a flock source: '" + spec.text + "'");
  FlockConfig c;
  c.path = spec.target;
  for (const auto& [k, v] : spec.params) {
    if (k == "birds")
      c.birds = std::stoi(v);
    else if (k == "baud")
      c.baud = std::stoi(v);
    else if (k == "erc")
      c.erc = parse_bool(v);
    else if (k == "format") {
      auto f = fl::parse_format(v);
      if (!f) return fail(Errc::invalid_argument, "flock: unknown format '" + v + "'");
      c.format = *f;
    } else if (k == "mode")
      c.stream = v != "point";
    else if (k == "hemisphere") {
      auto h = fl::parse_hemisphere(v);
      if (!h) return fail(Errc::invalid_argument, "flock: unknown hemisphere '" + v + "'");
      c.hemisphere = *h;
    } else if (k == "rate")
      c.measurement_rate_hz = std::stod(v);
    else if (k == "report")
      c.report_every = std::stoi(v);
    else if (k == "range")
      c.range_72in = v == "72";
    else if (k == "button")
      c.button = parse_bool(v);
    else if (k == "group")
      c.group = parse_bool(v);
    else if (k == "timeout_ms")
      c.stale_after = milliseconds(std::stoi(v));
    else
      return fail(Errc::invalid_argument, "flock: unknown parameter '" + k + "'");
  }
  return c;
}

struct FlockSource::Impl {
  FlockConfig cfg;
  std::unique_ptr<SerialPort> port;
  SpscQueue<SensorSample> queue;
  std::thread thread;
  std::atomic<bool> stop{false};

  // Status, read by other threads.
  std::atomic<DeviceState> state{DeviceState::disconnected};
  std::atomic<uint64_t> records{0}, resyncs_base{0}, reconnects{0}, dropped{0};
  std::atomic<uint64_t> decoder_resyncs{0};
  mutable std::mutex mu;
  std::string last_error;
  FlockInfo info;

  // Error query handshake.
  std::mutex req_mu;
  std::condition_variable req_cv;
  struct ExamineRequest {
    uint8_t parameter = 0;
    int address = -1;
  };
  std::optional<ExamineRequest> request;
  std::optional<Result<std::vector<uint8_t>>> answer;

  // Reader-thread state.
  fl::StreamDecoder decoder;
  std::vector<int> sensors;
  bool standalone = true;
  fl::PositionRange range = fl::PositionRange::in36;
  bool initialized_once = false;
  Clock::time_point last_record;
  uint64_t cycles = 0;
  int last_address = 1 << 30;
  double cycle_period_s = 0.01;
  std::array<uint8_t, 4096> buf{};

  explicit Impl(FlockConfig c) : cfg(std::move(c)), queue(cfg.queue_capacity) {}

  int master() const { return standalone ? -1 : 1; }
  int addr(int a) const { return standalone ? -1 : a; }  // prefix argument for a sensor
  int first_bird_address() const { return cfg.erc && !standalone ? 2 : 1; }
  double byte_time_s() const { return 10.0 / cfg.baud; }

  void set_error(std::string e) {
    std::lock_guard lock(mu);
    last_error = std::move(e);
  }

  bool sleep_interruptible(milliseconds d) {
    const auto until = Clock::now() + d;
    while (Clock::now() < until) {
      if (stop.load()) return false;
      std::this_thread::sleep_for(std::min<Clock::duration>(milliseconds(10), until - Clock::now()));
    }
    return !stop.load();
  }

  Status send(const std::vector<uint8_t>& bytes) { return port->write(bytes); }

  Result<std::vector<uint8_t>> examine(uint8_t parameter, int address) {
    std::vector<uint8_t> c;
    fl::append_examine(c, parameter, address);
    if (auto w = send(c); !w) return tl::unexpected(w.error());
    std::vector<uint8_t> reply(static_cast<size_t>(fl::examine_size(parameter)));
    if (auto r = port->read_exact(reply, cfg.reply_timeout); !r) {
      if (r.error().code == Errc::timeout) {
        return fail(Errc::timeout, "flock: no answer to EXAMINE " + std::to_string(parameter) +
                                       (address >= 0 ? " at FBB address " + std::to_string(address) : "") + " on " +
                                       cfg.path + " (powered, cabled, at " + std::to_string(cfg.baud) +
                                       " baud?): " + r.error().message);
      }
      return tl::unexpected(r.error());
    }
    return reply;
  }

  Status open_port() {
    port.reset();
    auto p = SerialPort::open(cfg.path, SerialOptions{cfg.baud, 1, false});
    if (!p) return tl::unexpected(p.error());
    port = std::move(*p);
    port->set_tap(cfg.tap);
    return {};
  }

  // Stops any output and discards what is in flight.
  Status quiesce() {
    if (auto w = send({fl::cmd::kPoint}); !w) return w;
    if (!sleep_interruptible(cfg.settle)) return fail(Errc::disconnected, "stopped");
    port->flush_input();
    return {};
  }

  // The start-up sequence (device-protocols.md §1.9, with the waits the manual asks for).
  Status initialize() {
    state = DeviceState::connecting;
    if (!port) {
      if (auto s = open_port(); !s) return s;
    }
    // RTS is the reset line. On a pty or a 3-wire cable there is none: skip the long waits.
    auto rts = port->set_rts(true);
    if (!rts) return tl::unexpected(rts.error());
    if (*rts) {
      port->set_dtr(true);
      if (!sleep_interruptible(cfg.reset_hold)) return fail(Errc::disconnected, "stopped");
      port->set_rts(false);
      if (!sleep_interruptible(cfg.reset_settle)) return fail(Errc::disconnected, "stopped");
    }
    if (auto s = quiesce(); !s) return s;

    FlockInfo found;
    Result<std::vector<uint8_t>> st = fail(Errc::timeout, "");
    for (int attempt = 0; attempt < 3 && !stop.load(); ++attempt) {
      st = examine(fl::param::kStatus, -1);
      if (st || st.error().code != Errc::timeout) break;
      // A reply that was only late (a loaded host, a slow adapter) still arrives: let it come in
      // and go, or every later reply would be read one behind.
      if (!sleep_interruptible(std::max<milliseconds>(cfg.settle, cfg.reply_timeout / 2)))
        return fail(Errc::disconnected, "stopped");
      port->flush_input();
    }
    if (!st) return tl::unexpected(st.error());
    auto rev = examine(fl::param::kSoftwareRevision, -1);
    if (!rev) return tl::unexpected(rev.error());
    found.software_revision = fl::software_revision_text(static_cast<uint16_t>(fl::get_le16(rev->data())));
    auto xtal = examine(fl::param::kCrystalSpeed, -1);
    if (!xtal) return tl::unexpected(xtal.error());
    found.crystal_mhz = (*xtal)[0];
    if (found.crystal_mhz <= 0) found.crystal_mhz = 25;
    auto model = examine(fl::param::kSystemModel, -1);
    if (!model) return tl::unexpected(model.error());
    found.model.assign(model->begin(), model->end());
    while (!found.model.empty() && (found.model.back() == ' ' || found.model.back() == '\0')) found.model.pop_back();

    standalone = cfg.birds == 1 && !cfg.erc;
    sensors.clear();
    for (int i = 0; i < cfg.birds; ++i) sensors.push_back(standalone ? 0 : i + 1 + (cfg.erc ? 1 : 0));
    range = cfg.erc ? fl::PositionRange::in144 : (cfg.range_72in ? fl::PositionRange::in72 : fl::PositionRange::in36);

    std::vector<uint8_t> c;
    c.push_back(fl::cmd::kRun);  // wake a flock left asleep by a previous 'G'
    if (auto w = send(c); !w) return w;

    if (!standalone) {
      c.clear();
      fl::append_auto_config(c, cfg.birds + (cfg.erc ? 1 : 0));
      if (auto w = send(c); !w) return w;
      // The master is deaf while it configures the bus.
      if (!sleep_interruptible(cfg.auto_config_wait)) return fail(Errc::disconnected, "stopped");
      port->flush_input();
      auto fs = examine(fl::param::kFlockStatus, -1);
      if (!fs) return tl::unexpected(fs.error());
      found.flock_status = *fs;
      for (int a : sensors) {
        const uint8_t b = (*fs)[static_cast<size_t>(a - 1)];
        const uint8_t need = fl::kUnitAccessible | fl::kUnitRunning | fl::kUnitSensor;
        if ((b & need) != need) {
          return fail(Errc::io_error, "flock: bird at FBB address " + std::to_string(a) +
                                          " is not running after auto-configuration (flock status " + hex2(b) + ")");
        }
      }
    }

    c.clear();
    for (int a : sensors) {
      fl::append_format(c, cfg.format, addr(a));
      fl::append_hemisphere(c, cfg.hemisphere, addr(a));
      fl::append_button_mode(c, cfg.button, addr(a));
      if (!cfg.erc) fl::append_change_word(c, fl::param::kPositionScaling, cfg.range_72in ? 1 : 0, addr(a));
    }
    if (cfg.measurement_rate_hz > 0) {
      fl::append_change_word(
          c, fl::param::kMeasurementRateCount,
          static_cast<int16_t>(fl::measurement_rate_count(cfg.measurement_rate_hz, found.crystal_mhz)));
    }
    c.push_back(*fl::report_rate_command(cfg.report_every));
    if (!standalone) fl::append_group_mode(c, cfg.group);
    if (auto w = send(c); !w) return w;

    auto count = examine(fl::param::kMeasurementRateCount, -1);
    if (!count) return tl::unexpected(count.error());
    found.measurement_rate_hz =
        fl::measurement_rate_hz(static_cast<uint16_t>(fl::get_le16(count->data())), found.crystal_mhz);
    auto err = examine(fl::param::kExpandedErrorCode, -1);
    if (!err) return tl::unexpected(err.error());
    if ((*err)[0] != 0) {
      set_error("flock: device reports error " + std::to_string((*err)[0]) + " (" + fl::error_name((*err)[0]) +
                ") after start-up");
    }
    found.sensor_addresses = sensors;

    const bool group_bytes = !standalone && cfg.group;
    decoder.set_layout(fl::RecordLayout{cfg.format, cfg.button, group_bytes});
    uint32_t mask = 0;
    for (int a : sensors) mask |= 1u << a;
    decoder.set_valid_addresses(mask);
    cycle_period_s = cfg.report_every / std::max(1.0, found.measurement_rate_hz);
    {
      std::lock_guard lock(mu);
      found.realtime = info.realtime;
      info = found;
    }
    port->flush_input();
    if (cfg.stream) {
      if (auto w = send({fl::cmd::kStream}); !w) return w;
    }
    last_record = Clock::now();
    return {};
  }

  void handle_record(const fl::RawRecord& r, double host_time_s, int polled_address) {
    const fl::Measurement m = fl::from_raw(r, range);
    SensorSample s = fl::to_sample(m, r.layout, static_cast<uint16_t>(standalone ? 1 : polled_address));
    // Sensors are numbered as the layouts number them, in address order: the first bird is
    // sensor 0 (the ERC, when there is one, holds address 1 and carries no sensor).
    s.sensor = static_cast<uint16_t>(s.sensor - first_bird_address());
    if (r.layout.group && r.address <= last_address) ++cycles;
    if (!r.layout.group) ++cycles;
    last_address = r.address;
    s.host_time_s = host_time_s;
    s.device_time_s = cfg.stream ? static_cast<double>(cycles) * cycle_period_s : host_time_s;
    if (!queue.push(s)) dropped.fetch_add(1, std::memory_order_relaxed);
    records.fetch_add(1, std::memory_order_relaxed);
    last_record = Clock::now();
  }

  // Reads for at most `timeout` and decodes; returns false when the port failed.
  bool pump(milliseconds timeout, int polled_address, int* got = nullptr) {
    auto n = port->read_some(buf, timeout);
    const Clock::time_point t_read = Clock::now();
    if (!n) {
      set_error("flock: " + n.error().message);
      port.reset();
      state = DeviceState::disconnected;
      return false;
    }
    const double t = seconds_of(t_read);
    const size_t total = *n;
    decoder.feed(std::span<const uint8_t>(buf.data(), total), [&](const fl::RawRecord& r, size_t end) {
      // A chunk can hold several records: each one's last byte arrived earlier by the bytes after it.
      handle_record(r, t - static_cast<double>(total - end) * byte_time_s(), polled_address);
      if (got) ++*got;
    });
    decoder_resyncs.store(decoder.resyncs(), std::memory_order_relaxed);
    return true;
  }

  // Answers an EXAMINE posted by another thread: output stops, the reply is read, the stream
  // resumes. Records in flight are discarded with the stale output.
  void serve_request() {
    ExamineRequest req;
    {
      std::lock_guard lock(req_mu);
      if (!request) return;
      req = *request;
    }
    Result<std::vector<uint8_t>> result = fail(Errc::disconnected, "flock: port closed");
    if (port) {
      if (auto q = quiesce(); !q)
        result = tl::unexpected(q.error());
      else
        result = examine(req.parameter, standalone ? -1 : req.address);
      if (port) {
        port->flush_input();
        decoder.reset();
        if (cfg.stream) send({fl::cmd::kStream});
      }
      last_record = Clock::now();
    }
    std::lock_guard lock(req_mu);
    request.reset();
    answer = std::move(result);
    req_cv.notify_all();
  }

  void run_connected() {
    const auto now = Clock::now();
    if (cfg.stream) {
      pump(milliseconds(10), 0);
    } else {
      // Point mode: one request in flight at a time (the flock objects otherwise).
      const auto next =
          now + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(1.0 / cfg.point_rate_hz));
      const bool per_bird = !standalone && !cfg.group;
      const std::vector<int> targets = per_bird ? sensors : std::vector<int>{standalone ? -1 : 1};
      for (int target : targets) {
        std::vector<uint8_t> c;
        fl::append_command(c, fl::cmd::kPoint, per_bird ? target : -1);
        if (!send(c)) {
          port.reset();
          state = DeviceState::disconnected;
          return;
        }
        const int expect = per_bird || standalone ? 1 : static_cast<int>(sensors.size());
        int got = 0;
        const auto deadline = Clock::now() + cfg.reply_timeout;
        while (got < expect && Clock::now() < deadline && !stop.load()) {
          if (!pump(milliseconds(5), per_bird ? target : 1, &got)) return;
        }
      }
      std::this_thread::sleep_until(next);
    }
  }

  void run() {
    bool need_init = false;  // start() ran the first initialisation
    while (!stop.load()) {
      serve_request();
      if (need_init || !port) {
        if (auto s = initialize(); !s) {
          set_error(s.error().message);
          state = DeviceState::disconnected;
          if (s.error().code == Errc::disconnected || s.error().code == Errc::not_found ||
              s.error().code == Errc::io_error)
            port.reset();
          sleep_interruptible(cfg.retry_every);
          continue;
        }
        need_init = false;
        reconnects.fetch_add(1);
        set_error("");
        state = DeviceState::streaming;
      }
      run_connected();
      if (!port) continue;
      const auto silent = Clock::now() - last_record;
      if (silent > cfg.reinit_after) {
        set_error("flock: no records for " + std::to_string(std::chrono::duration_cast<milliseconds>(silent).count()) +
                  " ms; restarting the device");
        state = DeviceState::disconnected;
        need_init = true;
      } else if (silent > cfg.stale_after) {
        state = DeviceState::stale;
      } else {
        state = DeviceState::streaming;
      }
    }
    if (port) {
      // Leave the flock quiet and asleep, as drivers do on shutdown.
      send({fl::cmd::kPoint, fl::cmd::kSleep});
      port.reset();
    }
    state = DeviceState::disconnected;
  }
};

FlockSource::FlockSource(FlockConfig config) : impl_(std::make_unique<Impl>(std::move(config))) {}

FlockSource::~FlockSource() { stop(); }

Status FlockSource::start() {
  Impl& m = *impl_;
  if (m.thread.joinable()) return fail(Errc::invalid_argument, "flock: already started");
  const FlockConfig& c = m.cfg;
  if (c.birds < 1 || c.birds + (c.erc ? 1 : 0) > 14)
    return fail(Errc::invalid_argument, "flock: birds must be 1..14 (13 with an ERC)");
  if (!fl::report_rate_command(c.report_every))
    return fail(Errc::invalid_argument, "flock: report_every must be 1, 2, 8 or 32");
  if (c.measurement_rate_hz != 0 && (c.measurement_rate_hz < 14 || c.measurement_rate_hz > 144))
    return fail(Errc::out_of_range, "flock: measurement rate must be 14..144 Hz");
  if (c.stream && !c.group && c.birds + (c.erc ? 1 : 0) > 1)
    return fail(Errc::invalid_argument, "flock: stream mode with several birds needs group mode");
  m.stop = false;
  if (auto s = m.initialize(); !s) {
    m.port.reset();
    m.state = DeviceState::disconnected;
    m.set_error(s.error().message);
    return s;
  }
  m.state = DeviceState::streaming;
  m.thread = std::thread([&m] {
    if (m.cfg.realtime_priority > 0) {
      const bool ok = set_thread_fifo(std::clamp(m.cfg.realtime_priority, 1, 99));
      std::lock_guard lock(m.mu);
      m.info.realtime = ok;
    }
    m.run();
  });
  return {};
}

size_t FlockSource::poll(std::span<SensorSample> out) { return impl_->queue.pop(out); }

DeviceStatus FlockSource::status() const {
  const Impl& m = *impl_;
  DeviceStatus s;
  s.state = m.state.load();
  s.records = m.records.load();
  s.resyncs = m.decoder_resyncs.load();
  s.reconnects = m.reconnects.load();
  std::lock_guard lock(m.mu);
  s.last_error = m.last_error;
  char rate[32];
  std::snprintf(rate, sizeof rate, "%.1f Hz", m.info.measurement_rate_hz);
  s.description = "flock:" + m.cfg.path + " " + std::to_string(m.cfg.birds) +
                  (m.cfg.birds == 1 ? " bird, " : " birds, ") + std::to_string(m.cfg.baud) + " baud, " +
                  fl::format_name(m.cfg.format) + (m.cfg.stream ? ", stream" : ", point");
  if (!m.info.model.empty()) s.description += ", " + m.info.model + " " + m.info.software_revision + ", " + rate;
  return s;
}

void FlockSource::stop() {
  Impl& m = *impl_;
  m.stop = true;
  if (m.thread.joinable()) m.thread.join();
  m.port.reset();
}

FlockInfo FlockSource::info() const {
  std::lock_guard lock(impl_->mu);
  return impl_->info;
}

Result<std::vector<uint8_t>> FlockSource::examine(uint8_t parameter, int address, std::chrono::milliseconds timeout) {
  Impl& m = *impl_;
  if (fl::examine_size(parameter) == 0)
    return fail(Errc::invalid_argument, "flock: no EXAMINE parameter " + std::to_string(parameter));
  if (!m.thread.joinable()) return fail(Errc::disconnected, "flock: not started");
  std::unique_lock lock(m.req_mu);
  m.answer.reset();
  m.request = Impl::ExamineRequest{parameter, address};
  if (!m.req_cv.wait_for(lock, timeout, [&] { return m.answer.has_value(); })) {
    m.request.reset();
    return fail(Errc::timeout, "flock: EXAMINE " + std::to_string(parameter) + " not answered in time");
  }
  return std::move(*m.answer);
}

Result<FlockError> FlockSource::query_error(std::chrono::milliseconds timeout) {
  auto r = examine(fl::param::kExpandedErrorCode, -1, timeout);
  if (!r) return tl::unexpected(r.error());
  return FlockError{(*r)[0], (*r)[1] & 0x0F, fl::error_name((*r)[0])};
}

Result<fl::BirdStatus> FlockSource::query_status(int address, std::chrono::milliseconds timeout) {
  auto r = examine(fl::param::kStatus, address, timeout);
  if (!r) return tl::unexpected(r.error());
  return fl::decode_status(static_cast<uint16_t>(fl::get_le16(r->data())));
}

uint64_t FlockSource::dropped_samples() const { return impl_->dropped.load(); }

}  // namespace mimic::devices
