#include "mimic/sim/open_source.h"

#include <cmath>
#include <cstdio>

#include "mimic/rig/motion.h"
#include "mimic/sim/sim_source.h"

// The Flock driver is optional at build time: the spec scheme exists either way, and a build
// without the driver says so instead of failing to compile.
#if __has_include("mimic/devices/flock.h")
#include "mimic/devices/flock.h"
#define MIMIC_SIM_HAVE_FLOCK 1
#else
#define MIMIC_SIM_HAVE_FLOCK 0
#endif

// BVH clips retargeted onto Mimic's skeleton, when the retargeting code is built in.
#if __has_include("mimic/rig/retarget.h")
#include "mimic/rig/retarget.h"
#define MIMIC_SIM_HAVE_BVH_MOTION 1
#else
#define MIMIC_SIM_HAVE_BVH_MOTION 0
#endif

namespace mimic::sim {

namespace {

// Plays a clip again and again (bvh:CLIP?loop=1); clips hold their last frame otherwise.
class LoopedMotion final : public rig::Motion {
 public:
  explicit LoopedMotion(std::unique_ptr<rig::Motion> inner) : inner_(std::move(inner)) {}
  const rig::Skeleton& skeleton() const override { return inner_->skeleton(); }
  double duration_s() const override { return inner_->duration_s(); }
  bool loops() const override { return true; }
  void sample(double t_s, rig::Pose& out) const override {
    const double d = inner_->duration_s();
    inner_->sample(d > 0 ? t_s - d * std::floor(t_s / d) : 0.0, out);
  }
  std::string name() const override { return inner_->name(); }

 private:
  std::unique_ptr<rig::Motion> inner_;
};

std::string describe_rig(const std::string& what, const RigConfig& c) {
  char text[160];
  std::snprintf(text, sizeof text, ", %zu sensors, %g Hz, noise %g mm / %g deg, seed %llu", c.sensors.size(), c.rate_hz,
                c.position_noise_mm, c.orientation_noise_deg, static_cast<unsigned long long>(c.seed));
  return what + text;
}

Result<std::unique_ptr<devices::SensorSource>> rig_source(const devices::SourceSpec& spec,
                                                          std::shared_ptr<const rig::Motion> motion,
                                                          std::shared_ptr<const Clock> clock) {
  auto config = rig_config_from_spec(spec, motion->skeleton());
  if (!config) return tl::unexpected(config.error());
  const std::string what = spec.scheme + ":" + (spec.target.empty() ? motion->name() : spec.target);
  const std::string description = describe_rig(what, *config);
  auto rig = SensorRig::create(std::move(motion), std::move(*config));
  if (!rig) return tl::unexpected(rig.error());
  return std::unique_ptr<devices::SensorSource>(new SimSource(std::move(*rig), std::move(clock), description));
}

}  // namespace

Result<std::unique_ptr<devices::SensorSource>> open_sensor_source(const devices::SourceSpec& spec,
                                                                  std::shared_ptr<const Clock> clock,
                                                                  std::shared_ptr<devices::ByteTap> tap,
                                                                  const rig::Skeleton* performer) {
  if (!clock) clock = std::make_shared<SteadyClock>();
  if (spec.scheme == "sim") {
    auto skeleton = performer ? Result<rig::Skeleton>(*performer) : rig::Skeleton::build(rig::default_skeleton_desc());
    if (!skeleton) return tl::unexpected(skeleton.error());
    auto motion = rig::make_builtin_motion(spec.target.empty() ? "walk" : spec.target, *skeleton);
    if (!motion) return tl::unexpected(motion.error());
    return rig_source(spec, std::shared_ptr<const rig::Motion>(std::move(*motion)), std::move(clock));
  }
  if (spec.scheme == "bvh") {
#if MIMIC_SIM_HAVE_BVH_MOTION
    rig::BvhMotionOptions options;
    options.body = performer;
    auto motion = rig::load_bvh_motion(spec.target, options);
    if (!motion) return tl::unexpected(motion.error());
    std::shared_ptr<const rig::Motion> shared;
    const auto loop = spec.params.find("loop");
    if (loop != spec.params.end() &&
        (loop->second == "1" || loop->second == "true" || loop->second == "yes" || loop->second == "on"))
      shared = std::make_shared<LoopedMotion>(std::move(*motion));
    else
      shared = std::shared_ptr<const rig::Motion>(std::move(*motion));
    return rig_source(spec, std::move(shared), std::move(clock));
#else
    return fail(Errc::unsupported, "source '" + spec.text + "': BVH-driven motion is not built into this version");
#endif
  }
  if (spec.scheme == "replay") {
    auto options = replay_options_from_spec(spec);
    if (!options) return tl::unexpected(options.error());
    auto replay = ReplaySource::open(spec.target, *options, std::move(clock));
    if (!replay) return tl::unexpected(replay.error());
    return std::unique_ptr<devices::SensorSource>(std::move(*replay));
  }
  if (spec.scheme == "flock") {
#if MIMIC_SIM_HAVE_FLOCK
    auto config = devices::flock_config_from_spec(spec);
    if (!config) return tl::unexpected(config.error());
    config->tap = std::move(tap);
    return std::unique_ptr<devices::SensorSource>(new devices::FlockSource(std::move(*config)));
#else
    (void)tap;
    return fail(Errc::unsupported,
                "source '" + spec.text + "': the Flock of Birds driver is not built into this version");
#endif
  }
  if (spec.scheme == "spaceball" || spec.scheme == "magellan" || spec.scheme == "spacemouse")
    return fail(Errc::unsupported, "source '" + spec.text + "': a " + spec.scheme +
                                       " gives 6-DOF input (translation/rotation deflections), not tracker samples");
  if (spec.scheme == "vmc")
    return fail(Errc::unsupported,
                "source '" + spec.text +
                    "': VMC brings poses its sender has solved, not tracker samples: it drives "
                    "`mimic run` and `mimic view` (recording and calibrating from VMC are not supported)");
  return fail(Errc::unsupported, "source '" + spec.text + "': scheme '" + spec.scheme + "' is not a tracker source");
}

}  // namespace mimic::sim
