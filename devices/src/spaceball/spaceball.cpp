#include "mimic/devices/spaceball.h"

#include <cstdio>
#include <cstdlib>

#include "serial_input_driver.h"
#include "spec_params.h"

namespace mimic::devices {

namespace {

using namespace spaceball;

constexpr std::string_view kReset = "\r@RESET\r";
constexpr std::string_view kConfigure = "\rCB\rNT\rFTp\rFRp\rP@r@r\rMSSV\rZ\rk\rhm\r";

class SpaceballDriver final : public detail::SerialInputDriver {
 public:
  explicit SpaceballDriver(SpaceballOptions o)
      : SerialInputDriver("spaceball", o.path, {o.baud, 1, false},
                          {o.probe_after_s, o.dead_after_s, o.reconnect_interval_s}),
        opt_(std::move(o)) {}
  ~SpaceballDriver() override { shutdown(); }

 protected:
  void on_open(double now_s) override {
    framer_.reset();
    counted_drops_ = framer_.dropped();
    model_ = Model::unknown;
    firmware_ = 0;
    advanced_keys_ = false;
    right_handed_ = true;
    buttons_ = 0;
    frame_ = {};
    reset_sent_s_ = now_s;
    configured_ = false;
    write(kReset);
  }

  void on_bytes(std::span<const uint8_t> bytes, double now_s) override {
    for (uint8_t b : bytes) {
      if (framer_.push(b)) handle(decode(framer_.packet()), now_s);
    }
    if (framer_.dropped() != counted_drops_) {
      count_resync(framer_.dropped() - counted_drops_);
      counted_drops_ = framer_.dropped();
    }
  }

  void on_tick(double now_s) override {
    if (!configured_ && now_s - reset_sent_s_ > opt_.reset_timeout_s) {
      reset_sent_s_ = now_s;
      write(kReset);
    }
  }

  void send_probe() override { write("\rk\r"); }

 private:
  void handle(const Packet& p, double now_s) {
    switch (p.kind) {
      case PacketKind::banner:
        if (p.banner_reset) {
          configured_ = true;
          write(kConfigure);
        }
        if (p.firmware_x100) note_identity(p.model, p.firmware_x100);
        break;
      case PacketKind::model:
        note_identity(p.model, p.firmware_x100);
        if (p.model == Model::sb4000flx) write("\"\r");
        configured_ = true;
        set_ready();
        break;
      case PacketKind::descriptor:
        if (p.model != Model::unknown || p.firmware_x100) note_identity(p.model, p.firmware_x100);
        right_handed_ = p.right_handed;
        break;
      case PacketKind::displacement:
        count_record();
        configured_ = true;
        set_ready();
        to_frame(p.axes, opt_.scaling, frame_);
        emit(now_s);
        break;
      case PacketKind::keys:
        if (advanced_keys_) break;  // the 4000 FLX repeats its keys in K for old hosts
        count_record();
        buttons_ = p.buttons;
        emit(now_s);
        break;
      case PacketKind::advanced_keys:
        count_record();
        if (!advanced_keys_) {
          advanced_keys_ = true;
          note_identity(Model::sb4000flx, firmware_);
        }
        right_handed_ = p.right_handed;
        buttons_ = p.buttons;
        emit(now_s);
        break;
      case PacketKind::error: {
        char text[48];
        std::snprintf(text, sizeof text, "device reported error bits %04x", p.error_bits);
        set_last_error(text);
        break;
      }
      case PacketKind::bad_command: set_last_error("device rejected a command"); break;
      case PacketKind::echo: break;
      case PacketKind::none: count_resync(); break;
    }
  }

  void emit(double now_s) {
    frame_.buttons = buttons_;
    frame_.host_time_s = now_s;
    publish(frame_);
  }

  void note_identity(Model m, uint16_t fw) {
    if (m != Model::unknown) model_ = m;
    if (fw) firmware_ = fw;
    if (model_ == Model::unknown && firmware_) model_ = model_from_firmware(firmware_);
    std::string id = std::string("Spaceball ") + model_name(model_);
    if (firmware_) {
      char v[24];
      std::snprintf(v, sizeof v, " firmware %u.%02u", firmware_ / 100u, firmware_ % 100u);
      id += v;
    }
    if (advanced_keys_ || model_ == Model::sb4000flx) id += right_handed_ ? ", right-handed" : ", left-handed";
    set_identity(std::move(id));
  }

  SpaceballOptions opt_;
  Framer framer_;
  uint64_t counted_drops_ = 0;
  Model model_ = Model::unknown;
  uint16_t firmware_ = 0;
  bool advanced_keys_ = false;
  bool right_handed_ = true;
  bool configured_ = false;
  uint32_t buttons_ = 0;
  InputFrame frame_{};
  double reset_sent_s_ = 0;
};

}  // namespace

std::unique_ptr<InputSource> make_spaceball_source(SpaceballOptions options) {
  return std::make_unique<SpaceballDriver>(std::move(options));
}

Result<SpaceballOptions> spaceball_options(const SourceSpec& spec) {
  SpaceballOptions o;
  o.path = spec.target;
  if (o.path.empty()) return fail(Errc::invalid_argument, spec.text + ": a serial device path is required");
  detail::SpecParams p(spec);
  p.unsigned_param("baud", o.baud);
  p.double_param("probe", o.probe_after_s);
  p.double_param("dead", o.dead_after_s);
  p.double_param("reset", o.reset_timeout_s);
  p.float_param("tscale", o.scaling.translation_full_scale);
  p.float_param("rscale", o.scaling.rotation_full_scale);
  p.int_param("null", o.scaling.null_radius);
  if (auto r = p.finish(); !r) return tl::unexpected(r.error());
  return o;
}

}  // namespace mimic::devices
