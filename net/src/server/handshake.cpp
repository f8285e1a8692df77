// HELLO: the version, the shared secret for publishers, the session token (new or resumed), and
// for a subscriber the scene as it is now.
#include "server/secure_random.h"
#include "server/server_impl.h"

namespace mimic::net {

namespace {

bool secrets_equal(const std::string& a, const std::string& b) {
  // Constant time in the secret's length, so timing does not leak a prefix.
  unsigned diff = a.size() == b.size() ? 0u : 1u;
  for (size_t i = 0; i < b.size(); ++i) diff |= unsigned(uint8_t(i < a.size() ? a[i] : 0) ^ uint8_t(b[i]));
  return diff == 0;
}

}  // namespace

// 128 bits from the kernel's CSPRNG: no number of observed tokens says anything about the next.
SessionToken ServerImpl::new_token() const {
  SessionToken t;
  do secure_random_bytes(t.bytes);
  while (t.empty() || resume.count(t) || udp_sessions.count(t));
  return t;
}

void Session::on_hello(std::span<const uint8_t> packet) {
  Hello h;
  if (const Reject e = decode_hello(packet, h); e != Reject::ok) {
    count(e);
    srv.stats.sessions_closed_for_input++;
    refuse(e, "bad HELLO");
    return;
  }
  if (h.max_version < kMinProtocolVersion || h.min_version > kProtocolVersion) {
    count(Reject::unsupported_version);
    refuse(Reject::unsupported_version, "server speaks versions 2..2");
    return;
  }
  if (h.role == Role::publisher && !srv.opt.secret.empty() && !secret_accepted(h.secret)) return;
  if (h.role == Role::subscriber && (h.capabilities & kCapMesh) && h.mesh_lod < kMaxLods &&
      !(srv.opt.mesh_lods_served & (1u << h.mesh_lod))) {
    std::string served;
    for (int l = 0; l < kMaxLods; ++l)
      if (srv.opt.mesh_lods_served & (1u << l)) {
        if (!served.empty()) served += ',';
        served += std::to_string(l);
      }
    const std::string why = "mesh LOD " + std::to_string(h.mesh_lod) +
                            " is not served here (served: " + (served.empty() ? "none" : served) + ")";
    count(Reject::unavailable);
    refuse(Reject::unavailable, why.c_str());
    return;
  }
  hello_timer.cancel();
  role = h.role;
  name = h.name;
  caps = h.capabilities & srv.capabilities();
  if (h.role != Role::subscriber) caps &= ~uint32_t(kCapUdpPose);
  mesh_lod = (caps & kCapMesh) && h.mesh_lod < kMaxLods ? h.mesh_lod : kNoMesh;
  active = true;
  bool resumed = false;
  if (!h.resume_token.empty()) {
    // Hash lookup, then a constant-time comparison of all 16 bytes (SessionToken's ==).
    auto it = srv.resume.find(h.resume_token);
    if (it != srv.resume.end() && it->second.role == role) {
      resumed = true;
      token = h.resume_token;
      // A resumed subscriber is sent every model again: one queued on the dead connection (or
      // dropped unread by a client that stalled) may never have reached it.
      if (role == Role::publisher) reattach(it->second.slots);
      srv.resume.erase(it);
      srv.stats.resumed++;
    }
  }
  // The token also authenticates the UDP address a subscriber registers.
  if (!resumed) token = (caps & (kCapResume | kCapUdpPose)) ? srv.new_token() : SessionToken{};
  if (caps & kCapUdpPose) srv.udp_sessions[token] = this;
  // Any larger packet is a model or mesh, which only publishers send.
  reader.set_max_packet_bytes(role == Role::publisher ? kMaxPacketBytes : kMaxHelloBytes);
  if (role == Role::publisher)
    srv.stats.publishers++;
  else
    srv.stats.subscribers++;

  Welcome w;
  w.capabilities = caps;
  w.session_token = token;
  w.client_id = id;
  w.resumed = resumed;
  std::array<uint8_t, 64> buf{};
  queue_control(std::span<const uint8_t>(buf.data(), encode_welcome(w, buf)));
  if (role == Role::subscriber) {
    // The scene as it is now: a resumed subscriber drops avatars that left while it was away
    // (their removal may have been queued on the dead connection).
    std::vector<SceneEntry> scene;
    for (const auto& a : srv.avatars)
      if (a.live) scene.push_back({a.id, a.revision});
    std::vector<uint8_t> scene_packet(scene_packet_bytes(scene.size()));
    queue_control(std::span<const uint8_t>(scene_packet.data(), encode_scene(scene, scene_packet)));
    // Late joiner: every model it does not hold yet, then every latest pose, at once.
    for (auto& a : srv.avatars) {
      if (!a.live) continue;
      ensure_slot(a.id);
      send_model(a);
      mark_pose(a.id);
    }
  }
  // Everything a fan-out will fill for this session is sized here, on the event loop.
  srv.reserve_fanout();
  reserve_buffers();
  flush();
}

// The shared secret, checked at most once per back-off period per address: each wrong guess
// doubles the wait of its address (ServerOptions::secret_backoff_s), so guessing costs time.
bool Session::secret_accepted(const std::string& secret) {
  const auto now = Clock::now();
  auto it = srv.secret_failures.find(peer_address);
  if (it != srv.secret_failures.end() && now < it->second.until) {
    srv.stats.secret_backoffs++;
    count(Reject::unauthorized);
    refuse(Reject::unauthorized, "too many wrong secrets from this address: wait before trying again");
    return false;
  }
  if (secrets_equal(secret, srv.opt.secret)) {
    if (it != srv.secret_failures.end()) srv.secret_failures.erase(it);
    return true;
  }
  if (it == srv.secret_failures.end()) {
    // Bounded: expired entries go first, then the oldest address's record.
    constexpr size_t kMaxTracked = 4096;
    if (srv.secret_failures.size() >= kMaxTracked) srv.expire_secret_failures(now);
    if (srv.secret_failures.size() >= kMaxTracked) srv.secret_failures.erase(srv.secret_failures.begin());
    it = srv.secret_failures.emplace(peer_address, ServerImpl::SecretFailures{}).first;
  }
  auto& f = it->second;
  f.count = std::min(f.count + 1, 30);
  const double wait_s = std::min(srv.opt.secret_backoff_s * double(1u << (f.count - 1)), srv.opt.secret_backoff_max_s);
  f.until = now + seconds(wait_s);
  count(Reject::unauthorized);
  refuse(Reject::unauthorized, "publishers must present the shared secret");
  return false;
}

void ServerImpl::expire_secret_failures(Clock::time_point now) {
  // A record outlives its wait by the longest wait, so a slow guesser keeps its back-off.
  const auto keep = seconds(opt.secret_backoff_max_s);
  for (auto it = secret_failures.begin(); it != secret_failures.end();)
    it = now - it->second.until > keep ? secret_failures.erase(it) : std::next(it);
}

void Session::reattach(const std::map<uint8_t, uint16_t>& old_slots) {
  for (const auto& [slot, avatar_id] : old_slots) {
    Avatar* a = srv.avatar(avatar_id);
    if (!a || !a->orphaned) continue;
    a->owner = this;
    a->orphaned = false;
    slots[slot] = avatar_id;
  }
}

}  // namespace mimic::net
