// One broker connection as the nats.c examples build it: a single options object (servers,
// reconnect policy, credentials, callbacks), then connect. Internal to net/.
#pragma once

#include <atomic>
#include <condition_variable>
#include <functional>
#include <mutex>
#include <string>

#include <nats/nats.h>

#include "mimic/core/result.h"
#include "mimic/net/nats.h"
#include "nats/avatar_key.h"

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
  bool connected() const;
  std::string connected_url() const;
  uint64_t disconnects() const { return disconnects_; }
  uint64_t reconnects() const { return reconnects_; }
  std::string last_error() const;

 private:
  static void disconnected_cb(natsConnection*, void* self);
  static void reconnected_cb(natsConnection*, void* self);
  static void error_cb(natsConnection*, natsSubscription*, natsStatus, void* self);
  static void closed_cb(natsConnection*, void* self);
  void set_error(std::string e);
  natsConnection* nc_ = nullptr;
  std::atomic<uint64_t> disconnects_{0}, reconnects_{0};
  // The client runs callbacks on a thread of its own, the closed callback last: this object
  // waits for it before going away.
  std::mutex closed_mutex_;
  std::condition_variable closed_cv_;
  bool closed_ = false;
  mutable std::mutex error_mutex_;
  std::string last_error_;
};

// "nats: <status text> (<last error detail>)".
std::string describe(natsStatus s);
std::string bucket_name(const std::string& scene);
// The pose frames of one publisher's tick: mimic.S.poses.<publisher token>.
std::string poses_subject(const std::string& scene, const std::string& publisher_token);
std::string mesh_subject(const std::string& scene, const std::string& key, unsigned lod);
std::string mesh_want_subject(const std::string& scene, const std::string& key);
std::string status_subject(const std::string& scene, const std::string& publisher_token);

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

}  // namespace mimic::net::nats_detail
