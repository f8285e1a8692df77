// One broker connection as the nats.c examples build it: a single options object (servers,
// reconnect policy, credentials, callbacks), then connect. Internal to net/.
#pragma once

#include <atomic>
#include <condition_variable>
#include <functional>
#include <mutex>
#include <string>
#include <string_view>

#include <nats/nats.h>

#include "mimic/core/result.h"
#include "mimic/net/nats.h"
#include "avatar_key.h"

namespace mimic::net::nats_detail {

class Connection {
 public:
  // Called on the client's threads.
  std::function<void()> on_reconnected;  // also the first connect after a failed start

  // Connects; a broker that cannot be reached yet is not an error (the client keeps trying in
  // the background). Refused credentials, a bad URL: a clear error.
  Status open(const NatsOptions& options);
  ~Connection();
  void close();

  natsConnection* get() const { return nc_; }
  // From the client's state callbacks: an atomic read that never waits on the client's lock
  // (held by its reconnect thread through a whole connect attempt).
  bool connected() const { return up_.load(std::memory_order_acquire); }
  NatsLinkState state() const noexcept;
  std::string connected_url() const;
  uint64_t disconnects() const { return disconnects_; }
  uint64_t reconnects() const { return reconnects_; }
  std::string last_error() const;

 private:
  // What the client's callbacks are given: the connection while it lives. A callback the client
  // still delivers after close() gave up waiting for the closed callback finds no owner and
  // does nothing; the closed callback, the client's last, frees the anchor then.
  struct Anchor {
    std::mutex mutex;
    Connection* owner = nullptr;
    bool closed = false, orphaned = false;
  };
  static void disconnected_cb(natsConnection*, void* self);
  static void reconnected_cb(natsConnection*, void* self);
  static void error_cb(natsConnection*, natsSubscription*, natsStatus, void* self);
  static void closed_cb(natsConnection*, void* self);
  void set_error(std::string e);
  void set_up(bool up) noexcept;
  natsConnection* nc_ = nullptr;
  Anchor* anchor_ = nullptr;  // owned here until close() hands it to a late closed callback
  std::atomic<uint64_t> disconnects_{0}, reconnects_{0};
  std::atomic<bool> up_{false};
  // Monotonic microseconds: when the link last went down (0: up), and how long the last
  // outage lasted.
  std::atomic<int64_t> down_since_us_{0}, last_outage_us_{0};
  // The client runs callbacks on a thread of its own, the closed callback last: this object
  // waits for it before going away.
  std::mutex closed_mutex_;
  std::condition_variable closed_cv_;
  bool closed_ = false;
  mutable std::mutex error_mutex_;
  std::string last_error_;
};

// Addresses as shown in messages and stats: without the USER:PASSWORD@ an address may carry.
std::string redact_urls(std::string_view servers);
// "nats: <status text> (<last error detail>)".
std::string describe(natsStatus s);
std::string bucket_name(const std::string& scene);
// The pose frames of one publisher's tick: mimic.S.poses.<publisher token>.
std::string poses_subject(const std::string& scene, const std::string& publisher_token);
// A publisher's own keys: "P.K", its subject token and an avatar key. The bucket key of the
// avatar's model, and the tail of its mesh subjects, so that broker permissions can give each
// publisher's user its own keys and subjects alone (config/nats/).
std::string owned_key(const std::string& publisher_token, const std::string& key);
// "P.K" with P a subject token (1-64 of [A-Za-z0-9_-]) and K 16 lowercase hex digits.
bool is_owned_key(std::string_view text);
// mimic.S.mesh.P.K.L: mesh frames (and topology) of owned key P.K at LOD L.
std::string mesh_subject(const std::string& scene, const std::string& owned, unsigned lod);
// mimic.S.want.P.K: relays' requests for mesh frames of owned key P.K.
std::string mesh_want_subject(const std::string& scene, const std::string& owned);
std::string status_subject(const std::string& scene, const std::string& publisher_token);
// The last token of a subject (the publisher of mimic.S.poses.P and mimic.S.status.P).
std::string_view last_token(std::string_view subject);

// A relay's mesh_want message: the LOD, and whether it needs the topology too.
inline constexpr size_t kMeshWantBytes = 2;
inline constexpr uint8_t kMeshWantTopology = 1u << 0;
// Relays repeat their mesh_want this often; a publisher stops sending mesh frames when none has
// come for three periods.
inline constexpr int kMeshWantPeriod_ms = 1000;
inline constexpr int64_t kMeshWantTimeout_us = 3 * kMeshWantPeriod_ms * 1000;

// A publisher name as a subject token: anything but [A-Za-z0-9_-] becomes '_'.
std::string subject_token(const std::string& name);

// Monotonic microseconds (rate bounds and timeouts; never the wall clock).
int64_t monotonic_us() noexcept;

// The counters a publisher and a relay feed share, from their impl (which holds the
// connection `conn` and the counters by these names): the rest of NatsLinkStats is each one's own.
template <class Impl>
NatsLinkStats common_link_stats(const Impl& impl) {
  return NatsLinkStats{.connected = impl.conn.connected(),
                       .disconnects = impl.conn.disconnects(),
                       .reconnects = impl.conn.reconnects(),
                       .frames = impl.frames,
                       .frames_dropped = impl.dropped,
                       .models = impl.models,
                       .model_failures = impl.model_failures,
                       .mesh_frames = impl.mesh_frames,
                       .mesh_requests = impl.mesh_requests,
                       .last_error = {}};
}

}  // namespace mimic::net::nats_detail
