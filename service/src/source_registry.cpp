#include "mimic/service/source_registry.h"

#include "mimic/devices/source.h"

namespace mimic::service {
namespace {

Status check_device_spec(const std::string& text) {
  auto spec = devices::parse_source_spec(text);
  if (!spec) return tl::unexpected(spec.error());
  return {};
}

// Trackers and VMC: the spec parser's key tables (devices/source_spec.cpp) check them, open_feed
// opens them (samples through the solver; VMC poses as they come).
Result<std::unique_ptr<PoseFeed>> open_device_feed(const SourceRequest& r) {
  return open_feed(r.text, r.calibration, r.body);
}

Status check_actor(const std::string& text) {
  auto options = actor_options(text);
  if (!options) return tl::unexpected(options.error());
  return {};
}

Result<std::unique_ptr<PoseFeed>> open_actor(const SourceRequest& r) {
  return make_actor_feed(r.text, r.roster, r.slot, r.body);
}

const SourceScheme kSchemes[] = {
    {"sim", "sim:walk?sensors=11&seed=2", false, check_device_spec, open_device_feed},
    {"bvh", "bvh:CLIP.bvh?loop=1", false, check_device_spec, open_device_feed},
    {"replay", "replay:SESSION.mlog", false, check_device_spec, open_device_feed},
    {"flock", "flock:/dev/ttyUSB0?birds=4", false, check_device_spec, open_device_feed},
    {"vmc", "vmc:39539", false, check_device_spec, open_device_feed},
    {"vrpn", "vrpn:Tracker0@tracker-pc:3883?layout=6", false, check_device_spec, open_device_feed},
    {"osc-trackers", "osc-trackers:9000", false, check_device_spec, open_device_feed},
    {"actor", "actor:wander?seed=3", true, check_actor, open_actor},
};

}  // namespace

std::span<const SourceScheme> source_schemes() { return kSchemes; }

const SourceScheme* find_source_scheme(std::string_view text) {
  const std::string_view scheme = text.substr(0, text.find_first_of(":?"));
  for (const SourceScheme& s : kSchemes)
    if (scheme == s.scheme) return &s;
  return nullptr;
}

std::string source_scheme_list() {
  std::string list;
  for (const SourceScheme& s : kSchemes) list.append(list.empty() ? "" : ", ").append(s.scheme);
  return list;
}

Result<std::unique_ptr<PoseFeed>> open_source(const SourceRequest& request) {
  const SourceScheme* scheme = find_source_scheme(request.text);
  if (!scheme) {
    // A device the spec parser knows but that gives no poses (a spaceball, a SpaceMouse) is
    // refused by the opener with the reason; anything else is not a source at all.
    if (auto st = check_device_spec(request.text); !st) {
      if (st.error().message.find("unknown scheme") == std::string::npos) return tl::unexpected(st.error());
      const std::string name(request.text.substr(0, request.text.find_first_of(":?")));
      return fail(Errc::invalid_argument, "source '" + request.text + "': unknown scheme '" + name +
                                              "' (sources: " + source_scheme_list() + ")");
    }
    return open_device_feed(request);
  }
  if (auto st = scheme->check(request.text); !st) return tl::unexpected(st.error());
  return scheme->open(request);
}

}  // namespace mimic::service
