#include "mimic/devices/magellan.h"

#include <algorithm>

#include "../spaceball/serial_input_driver.h"
#include "../spaceball/spec_params.h"

namespace mimic::devices {

namespace {

using namespace magellan;

constexpr std::string_view kQuery = "vQ\r";
constexpr std::string_view kConfigure = "z\rm3\rc30\rnH\rbH\r";

class MagellanDriver final : public detail::SerialInputDriver {
 public:
  explicit MagellanDriver(MagellanOptions o)
      : SerialInputDriver("magellan", o.path, {o.baud, 2, true},
                          {o.probe_after_s, o.dead_after_s, o.reconnect_interval_s}),
        opt_(std::move(o)) {}
  ~MagellanDriver() override { shutdown(); }

 protected:
  void on_open(double now_s) override {
    framer_.reset();
    counted_drops_ = framer_.dropped();
    identified_ = false;
    next_query_s_ = now_s + opt_.settle_s;
    frame_ = {};
  }

  void on_bytes(std::span<const uint8_t> bytes, double now_s) override {
    for (uint8_t b : bytes) {
      if (framer_.push(b)) handle(framer_.packet(), now_s);
    }
    if (framer_.dropped() != counted_drops_) {
      count_resync(framer_.dropped() - counted_drops_);
      counted_drops_ = framer_.dropped();
    }
  }

  void on_tick(double now_s) override {
    if (!identified_ && now_s >= next_query_s_) {
      next_query_s_ = now_s + opt_.query_retry_s;
      write(kQuery);
    }
  }

  void send_probe() override {
    if (identified_) write(kQuery);
  }

 private:
  void handle(std::span<const uint8_t> raw, double now_s) {
    const Packet p = decode(raw);
    switch (p.kind) {
      case PacketKind::version: {
        std::string text(reinterpret_cast<const char*>(raw.data()) + 1, raw.size() - 1);
        text.erase(0, text.find_first_not_of(' '));
        text.erase(std::unique(text.begin(), text.end(), [](char a, char b) { return a == ' ' && b == ' '; }),
                   text.end());
        if (!is_known_version(text)) set_last_error("unrecognised version reply: " + text);
        set_identity(text);
        if (!identified_) {
          identified_ = true;
          write(kConfigure);
        }
        break;
      }
      case PacketKind::echo:
        if (p.echo_type == 'b') set_ready();
        break;
      case PacketKind::data:
        count_record();
        set_ready();
        to_frame(p.axes, opt_.scaling, frame_);
        emit(now_s);
        break;
      case PacketKind::keys:
        count_record();
        frame_.buttons = p.buttons;
        emit(now_s);
        break;
      case PacketKind::error:
        set_last_error("device reported an error: " +
                       std::string(reinterpret_cast<const char*>(raw.data()), raw.size()));
        break;
      case PacketKind::none: count_resync(); break;
    }
  }

  void emit(double now_s) {
    frame_.host_time_s = now_s;
    publish(frame_);
  }

  MagellanOptions opt_;
  Framer framer_;
  uint64_t counted_drops_ = 0;
  bool identified_ = false;
  double next_query_s_ = 0;
  InputFrame frame_{};
};

}  // namespace

std::unique_ptr<InputSource> make_magellan_source(MagellanOptions options) {
  return std::make_unique<MagellanDriver>(std::move(options));
}

Result<MagellanOptions> magellan_options(const SourceSpec& spec) {
  MagellanOptions o;
  o.path = spec.target;
  if (o.path.empty()) return fail(Errc::invalid_argument, spec.text + ": a serial device path is required");
  detail::SpecParams p(spec);
  p.unsigned_param("baud", o.baud);
  p.double_param("settle", o.settle_s);
  p.double_param("probe", o.probe_after_s);
  p.double_param("dead", o.dead_after_s);
  p.float_param("scale", o.scaling.full_scale);
  p.int_param("null", o.scaling.null_radius);
  if (auto r = p.finish(); !r) return tl::unexpected(r.error());
  return o;
}

}  // namespace mimic::devices
