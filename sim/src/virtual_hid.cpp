#include "mimic/sim/virtual_hid.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <thread>

#include "mimic/core/clock.h"
#include "mimic/devices/hid_spacemouse.h"

namespace mimic::sim {

namespace hid = devices::hid;

VirtualHid::VirtualHid(VirtualHidConfig config) : cfg_(std::move(config)) {
  model_ = hid::find_model(cfg_.vendor_id, cfg_.product_id);
  if (!model_) model_ = hid::find_model(hid::kVendorLogitech, 0xC626);
  if (!cfg_.input) cfg_.input = default_input_pattern(cfg_.seed);
}

void VirtualHid::advance(double now_s, const Emit& emit) {
  // 7-byte models send one report per 8 ms (1 and 2 alternate); 13-byte models one per 16 ms.
  const double period = model_->combined_axes ? 0.016 : 0.008;
  while (next_s_ <= now_s) {
    const double t = next_s_;
    next_s_ += period;
    const devices::InputFrame f = cfg_.input(t);
    const hid::Axes a = hid::from_frame(f, cfg_.scaling);
    const uint32_t b =
        model_->buttons ? f.buttons & ((model_->buttons >= 32) ? ~0u : (1u << model_->buttons) - 1) : f.buttons & 0x3u;
    if (b != buttons_) {
      buttons_ = b;
      std::array<uint8_t, 5> r{};
      const size_t n = hid::button_report(b, std::max<unsigned>(model_->buttons, 2), r);
      emit({r.data(), n});
    }
    const bool rest = std::all_of(a.begin(), a.end(), [](int16_t v) { return v == 0; });
    // Zeros go out three more times (three pairs on 7-byte models), then the device is quiet.
    const int zero_reports = model_->combined_axes ? 3 : 6;
    if (rest) {
      if (zero_repeats_left_ == 0) continue;
      --zero_repeats_left_;
    } else {
      zero_repeats_left_ = zero_reports;
    }
    if (model_->combined_axes) {
      const auto r = hid::combined_report(a);
      emit(r);
    } else if (rotation_next_) {
      const auto r = hid::rotation_report(a);
      emit(r);
    } else {
      const auto r = hid::translation_report(a);
      emit(r);
    }
    rotation_next_ = !rotation_next_;
  }
  if (model_->combined_axes && now_s >= next_battery_s_) {
    next_battery_s_ = now_s + cfg_.battery_period_s;
    const uint8_t r[2] = {0x17, static_cast<uint8_t>(battery_)};
    emit(r);
    if (battery_ > 5) --battery_;
  }
}

namespace {

class SimulatedSpaceMouse final : public devices::InputSource {
 public:
  explicit SimulatedSpaceMouse(VirtualHidConfig cfg) : hid_(cfg), core_(description(hid_.model()), cfg.scaling) {}
  ~SimulatedSpaceMouse() override { stop(); }

  Status start() override {
    if (running_.exchange(true)) return {};
    core_.start();
    thread_ = std::thread([this] { run(); });
    return {};
  }
  bool poll(devices::InputFrame& out) override { return core_.poll(out); }
  devices::DeviceStatus status() const override { return core_.status(); }
  void stop() override {
    running_.store(false);
    if (thread_.joinable()) thread_.join();
    core_.stop();
  }

 private:
  static std::string description(const hid::Model& m) {
    char ids[16];
    std::snprintf(ids, sizeof ids, "%04x:%04x", m.vendor_id, m.product_id);
    return std::string("spacemouse:sim ") + m.name + " (" + ids + ")";
  }

  void run() {
    const double t0_s = steady_now_s();
    while (running_.load()) {
      const double host = steady_now_s();
      const double now = host - t0_s;
      hid_.advance(now, [&](std::span<const uint8_t> r) { core_.feed(r, host); });
      std::this_thread::sleep_for(std::chrono::milliseconds(4));
    }
  }

  VirtualHid hid_;
  devices::HidReportSource core_;
  std::thread thread_;
  std::atomic<bool> running_{false};
};

}  // namespace

Result<std::unique_ptr<devices::InputSource>> make_simulated_spacemouse(VirtualHidConfig config) {
  if (!hid::find_model(config.vendor_id, config.product_id)) {
    char ids[16];
    std::snprintf(ids, sizeof ids, "%04x:%04x", config.vendor_id, config.product_id);
    return fail(Errc::invalid_argument, std::string("not a known 3Dconnexion 6-DOF device: ") + ids);
  }
  return std::unique_ptr<devices::InputSource>(std::make_unique<SimulatedSpaceMouse>(std::move(config)));
}

}  // namespace mimic::sim
