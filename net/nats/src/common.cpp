// Addresses, scene names and avatar keys of the broker transport.
#include <algorithm>
#include <cstdio>
#include <cstdlib>

#include "mimic/net/nats.h"
#include "avatar_key.h"

namespace mimic::net {

void nats_credentials_from_env(NatsOptions& options) {
  if (const char* v = std::getenv("MIMIC_NATS_USER")) options.user = v;
  if (const char* v = std::getenv("MIMIC_NATS_PASSWORD")) options.password = v;
  if (const char* v = std::getenv("MIMIC_NATS_TOKEN")) options.token = v;
}

int format_nats_state(const NatsLinkState& s, char* out, size_t size) noexcept {
  int n = 0;
  if (!s.connected)
    n = std::snprintf(out, size, " | nats DOWN %.1f s", s.down_s);
  else if (s.disconnects == 0)
    n = std::snprintf(out, size, " | nats up");
  else
    n = std::snprintf(out, size, " | nats up (%llu outage%s, last %.3f s)",
                      static_cast<unsigned long long>(s.disconnects), s.disconnects == 1 ? "" : "s", s.last_outage_s);
  return std::clamp(n, 0, size ? int(size) - 1 : 0);
}

bool is_nats_url(std::string_view text) { return text.starts_with("nats://") || text.starts_with("tls://"); }

Status check_scene_name(std::string_view scene) {
  // A subject token and a bucket name: no dots, wildcards or spaces.
  if (scene.empty() || scene.size() > 64) return fail(Errc::invalid_argument, "scene name must be 1 to 64 characters");
  for (char c : scene)
    if (!((c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_' || c == '-')) {
      std::string msg = "scene name '";
      msg.append(scene).append("' may only hold A-Z a-z 0-9 _ -");
      return fail(Errc::invalid_argument, msg);
    }
  return {};
}

Result<NatsTarget> parse_nats_target(std::string_view text) {
  if (!is_nats_url(text)) {
    std::string msg = "'";  // appended: GCC 12 warns falsely on chained + (-Wrestrict)
    msg.append(text).append("' is not a nats:// address");
    return fail(Errc::invalid_argument, msg);
  }
  NatsTarget t;
  t.scene = "default";
  std::string_view servers = text;
  // A '/' after the last scheme separator starts the scene name.
  const size_t scheme = text.rfind("://");
  if (const size_t slash = text.find('/', scheme + 3); slash != std::string_view::npos) {
    servers = text.substr(0, slash);
    if (slash + 1 < text.size()) t.scene = std::string(text.substr(slash + 1));
  }
  if (auto st = check_scene_name(t.scene); !st) return tl::unexpected(st.error());
  t.servers = std::string(servers);
  return t;
}

Status check_nats_options(const NatsOptions& o) {
  if (o.heartbeat_ms < 100 || o.heartbeat_ms > 60000)
    return fail(Errc::invalid_argument, "the heartbeat period must be 100 to 60000 ms");
  if (o.missed_heartbeats < 1 || o.missed_heartbeats > 100)
    return fail(Errc::invalid_argument, "missed heartbeats must be 1 to 100");
  if (!(o.model_ttl_s == 0 || (o.model_ttl_s >= kMinModelTtl_s && o.model_ttl_s <= kMaxModelTtl_s)))
    return fail(Errc::invalid_argument, "the model TTL must be 0 (models never expire) or 3 to 86400 seconds");
  if (!(o.mesh_max_hz >= kMinMeshHz && o.mesh_max_hz <= kMaxMeshHz))
    return fail(Errc::invalid_argument, "the mesh frame rate must be 1 to 240 per second");
  return {};
}

namespace nats_detail {

uint64_t avatar_key_value(std::string_view publisher, std::string_view avatar) {
  uint64_t h = 14695981039346656037ull;  // FNV-1a 64
  auto mix = [&h](std::string_view s) {
    for (unsigned char c : s) {
      h ^= c;
      h *= 1099511628211ull;
    }
  };
  mix(publisher);
  mix("/");
  mix(avatar);
  return h;
}

std::string avatar_key_text(uint64_t key) {
  static const char* hex = "0123456789abcdef";
  std::string out(16, '0');
  for (int i = 15; i >= 0; --i, key >>= 4) out[size_t(i)] = hex[key & 15];
  return out;
}

}  // namespace nats_detail

std::string nats_display_servers(std::string_view servers) {
  std::string out(servers);
  for (size_t scheme = out.find("://"); scheme != std::string::npos; scheme = out.find("://", scheme + 3)) {
    const size_t end = std::min(out.find(',', scheme), out.size());
    if (const size_t at = out.rfind('@', end); at != std::string::npos && at > scheme && at < end)
      out.erase(scheme + 3, at + 1 - (scheme + 3));
  }
  return out;
}

std::string nats_avatar_key(std::string_view publisher, std::string_view avatar) {
  return nats_detail::avatar_key_text(nats_detail::avatar_key_value(publisher, avatar));
}

}  // namespace mimic::net
