// Addresses, scene names and avatar keys of the broker transport.
#include <cstdlib>

#include "mimic/net/nats.h"

namespace mimic::net {

void nats_credentials_from_env(NatsOptions& options) {
  if (const char* v = std::getenv("MIMIC_NATS_USER")) options.user = v;
  if (const char* v = std::getenv("MIMIC_NATS_PASSWORD")) options.password = v;
  if (const char* v = std::getenv("MIMIC_NATS_TOKEN")) options.token = v;
}

bool is_nats_url(std::string_view text) { return text.starts_with("nats://") || text.starts_with("tls://"); }

Status check_scene_name(std::string_view scene) {
  // A subject token and a bucket name: no dots, wildcards or spaces.
  if (scene.empty() || scene.size() > 64)
    return fail(Errc::invalid_argument, "scene name must be 1 to 64 characters");
  for (char c : scene)
    if (!((c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_' || c == '-'))
    {
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

std::string nats_avatar_key(std::string_view publisher, std::string_view avatar) {
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
  static const char* hex = "0123456789abcdef";
  std::string out(16, '0');
  for (int i = 15; i >= 0; --i, h >>= 4) out[size_t(i)] = hex[h & 15];
  return out;
}

}  // namespace mimic::net
