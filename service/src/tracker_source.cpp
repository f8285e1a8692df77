#include "mimic/service/tracker_source.h"

#include "osc_tracker_source.h"
#include "tracker_map.h"
#include "vrpn_source.h"
#include "mimic/avatar/body_presets.h"
#include "mimic/sim/open_source.h"

namespace mimic::service {

bool is_network_tracker(const devices::SourceSpec& spec) {
  return spec.scheme == "vrpn" || spec.scheme == "osc-trackers" ||
         (spec.scheme == "vmc" && spec.params.count("map") > 0);
}

Result<std::unique_ptr<devices::SensorSource>> open_tracker_source(const devices::SourceSpec& spec,
                                                                   std::shared_ptr<const Clock> clock,
                                                                   std::shared_ptr<devices::ByteTap> tap,
                                                                   const rig::Skeleton* performer) {
  if (spec.scheme == "vrpn") return open_vrpn_source(spec, std::move(clock));
  if (spec.scheme == "osc-trackers") return open_osc_tracker_source(spec, std::move(clock));
  if (spec.scheme == "vmc") {
    if (!is_network_tracker(spec))
      return fail(Errc::invalid_argument,
                  "'" + spec.text +
                      "': VMC bones are a pose, not tracker samples (run and view take them; to read a VMC "
                      "sender's devices as trackers, name them: vmc:PORT?map=SERIAL:SEGMENT,...)");
    return open_vmc_device_source(spec, std::move(clock));
  }
  // A simulated wearer of another build: body=preset:NAME or body=FILE wears that body's skeleton.
  if (const auto body = spec.params.find("body");
      body != spec.params.end() && (spec.scheme == "sim" || spec.scheme == "bvh")) {
    auto model = avatar::load_body_or_preset(body->second);
    if (!model) return fail(Errc::invalid_argument, "'" + spec.text + "': body: " + model.error().message);
    auto wearer = rig::Skeleton::build(model->skeleton);
    if (!wearer) return fail(Errc::invalid_argument, "'" + spec.text + "': body: " + wearer.error().message);
    return sim::open_sensor_source(spec, std::move(clock), std::move(tap), &*wearer);
  }
  return sim::open_sensor_source(spec, std::move(clock), std::move(tap), performer);
}

Result<solver::SensorLayout> network_tracker_layout(const devices::SourceSpec& spec, const rig::Skeleton& skeleton) {
  if (spec.scheme == "vrpn") return vrpn_layout(spec, skeleton);
  if (spec.scheme == "osc-trackers") return osc_tracker_layout(spec, skeleton);
  if (is_network_tracker(spec)) return vmc_device_layout(spec, skeleton);
  return fail(Errc::invalid_argument, "'" + spec.text + "' is not a network tracker (vrpn:, osc-trackers:, vmc:?map=)");
}

sim::LogHeader tracker_log_header(const devices::SourceSpec& spec, const devices::SensorSource& source,
                                  const rig::Skeleton& skeleton) {
  sim::LogHeader h = sim::log_header_for(spec, source);
  if (!is_network_tracker(spec)) return h;
  if (auto layout = network_tracker_layout(spec, skeleton)) {
    for (const auto& b : layout->bindings) {
      rig::RigidTransform segment_from_sensor;
      segment_from_sensor.translation = b.placement_m;
      h.sensors.push_back({b.sensor, b.name, b.segment, segment_from_sensor});
    }
    h.description = "network tracker, sensors worn as " + layout->name;
  }
  return h;
}

}  // namespace mimic::service
