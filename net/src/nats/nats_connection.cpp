#if MIMIC_WITH_NATS
// Broker connection setup shared by the publisher and the relay feed.
#include "nats/nats_connection.h"

#include <chrono>
#include <cstdio>
#include <vector>

namespace mimic::net::nats_detail {

std::string describe(natsStatus s) {
  std::string out = natsStatus_GetText(s);
  natsStatus last = NATS_OK;
  if (const char* detail = nats_GetLastError(&last); detail && *detail && out.find(detail) == std::string::npos)
    out.append(" (").append(detail).append(")");
  return out;
}

std::string bucket_name(const std::string& scene) { return "mimic_" + scene; }
std::string poses_subject(const std::string& scene, const std::string& publisher_token) {
  return "mimic." + scene + ".poses." + publisher_token;
}
std::string subject_token(const std::string& name) {
  std::string s = name.empty() ? "mimic" : name.substr(0, 64);
  for (char& c : s)
    if (!((c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_' || c == '-')) c = '_';
  return s;
}
std::string mesh_subject(const std::string& scene, const std::string& key, unsigned lod) {
  return "mimic." + scene + "." + key + ".mesh." + std::to_string(lod);
}
std::string mesh_want_subject(const std::string& scene, const std::string& key) {
  return "mimic." + scene + "." + key + ".mesh_want";
}
std::string status_subject(const std::string& scene, const std::string& publisher_token) {
  return "mimic." + scene + ".status." + publisher_token;
}

int64_t monotonic_us() noexcept {
  return std::chrono::duration_cast<std::chrono::microseconds>(std::chrono::steady_clock::now().time_since_epoch())
      .count();
}

void Connection::disconnected_cb(natsConnection*, void* self) {
  static_cast<Connection*>(self)->disconnects_++;
}

void Connection::reconnected_cb(natsConnection*, void* self) {
  auto* c = static_cast<Connection*>(self);
  c->reconnects_++;
  if (c->on_reconnected) c->on_reconnected();
}

void Connection::error_cb(natsConnection*, natsSubscription*, natsStatus s, void* self) {
  static_cast<Connection*>(self)->set_error(natsStatus_GetText(s));
}

void Connection::closed_cb(natsConnection*, void* self) {
  auto* c = static_cast<Connection*>(self);
  std::lock_guard lock(c->closed_mutex_);
  c->closed_ = true;
  c->closed_cv_.notify_all();
}

void Connection::set_error(std::string e) {
  std::lock_guard lock(error_mutex_);
  last_error_ = std::move(e);
}

std::string Connection::last_error() const {
  std::lock_guard lock(error_mutex_);
  return last_error_;
}

std::string Connection::connected_url() const {
  char buf[256] = {};
  if (!connected() || natsConnection_GetConnectedUrl(nc_, buf, sizeof buf) != NATS_OK) return {};
  return buf;
}

bool Connection::connected() const { return nc_ && natsConnection_Status(nc_) == NATS_CONN_STATUS_CONNECTED; }

Status Connection::open(const NatsOptions& options) {
  std::vector<std::string> urls;
  for (size_t begin = 0; begin <= options.servers.size();) {
    size_t end = options.servers.find(',', begin);
    if (end == std::string::npos) end = options.servers.size();
    if (end > begin) urls.push_back(options.servers.substr(begin, end - begin));
    begin = end + 1;
  }
  if (urls.empty()) return fail(Errc::invalid_argument, "no NATS server address given");
  for (const auto& u : urls)
    if (!is_nats_url(u)) {
      std::string msg = "'";
      msg.append(u).append("' is not a nats://HOST:PORT address");
      return fail(Errc::invalid_argument, msg);
    }
  if (auto st = check_scene_name(options.scene); !st) return st;
  std::vector<const char*> c_urls;
  for (const auto& u : urls) c_urls.push_back(u.c_str());

  natsOptions* o = nullptr;
  if (natsOptions_Create(&o) != NATS_OK) return fail(Errc::io_error, "nats: " + describe(NATS_NO_MEMORY));
  struct Guard {
    natsOptions* o;
    ~Guard() { natsOptions_Destroy(o); }
  } guard{o};
  natsStatus s = natsOptions_SetServers(o, c_urls.data(), int(c_urls.size()));
  if (s == NATS_OK) s = natsOptions_SetName(o, options.name.c_str());
  if (s == NATS_OK) s = natsOptions_SetTimeout(o, int64_t(options.connect_timeout_s * 1000));
  if (s == NATS_OK) s = natsOptions_SetMaxReconnect(o, -1);  // a relay or publisher never gives up
  if (s == NATS_OK) s = natsOptions_SetReconnectWait(o, options.reconnect_wait_ms);
  // Pose frames are not buffered through an outage (they are checked against the connection
  // state first); this only bounds what a publish racing a disconnect may hold.
  if (s == NATS_OK) s = natsOptions_SetReconnectBufSize(o, 256 * 1024);
  if (s == NATS_OK && !options.randomize) s = natsOptions_SetNoRandomize(o, true);
  // Each publish goes out at once rather than waiting for the client's flusher: latency first.
  if (s == NATS_OK) s = natsOptions_SetSendAsap(o, true);
  if (s == NATS_OK) s = natsOptions_SetPingInterval(o, 2000);
  if (s == NATS_OK) s = natsOptions_SetMaxPingsOut(o, 2);
  if (s == NATS_OK && !options.token.empty()) s = natsOptions_SetToken(o, options.token.c_str());
  if (s == NATS_OK && !options.user.empty())
    s = natsOptions_SetUserInfo(o, options.user.c_str(), options.password.c_str());
  if (s == NATS_OK) s = natsOptions_SetDisconnectedCB(o, disconnected_cb, this);
  if (s == NATS_OK) s = natsOptions_SetReconnectedCB(o, reconnected_cb, this);
  if (s == NATS_OK) s = natsOptions_SetErrorHandler(o, error_cb, this);
  if (s == NATS_OK) s = natsOptions_SetClosedCB(o, closed_cb, this);
  if (s != NATS_OK) return fail(Errc::invalid_argument, "nats options: " + describe(s));

  s = natsConnection_Connect(&nc_, o);
  if (s == NATS_OK) return {};
  const std::string why = describe(s);
  const bool refused = s == NATS_CONNECTION_AUTH_FAILED || s == NATS_NOT_PERMITTED ||
                       why.find("uthorization") != std::string::npos || why.find("uthentication") != std::string::npos;
  if (refused)
    return fail(Errc::invalid_argument,
                "the NATS broker at " + options.servers + " refused the credentials (" + why +
                    "); set MIMIC_NATS_USER and MIMIC_NATS_PASSWORD, or MIMIC_NATS_TOKEN");
  if (s != NATS_NO_SERVER && s != NATS_TIMEOUT && s != NATS_IO_ERROR)
    return fail(Errc::io_error, "cannot connect to the NATS broker at " + options.servers + ": " + why);
  // Nobody answers yet: keep trying in the background; the callback reports the connect.
  set_error("broker unreachable: " + why);
  nc_ = nullptr;
  natsOptions_SetRetryOnFailedConnect(o, true, reconnected_cb, this);
  s = natsConnection_Connect(&nc_, o);
  if (s == NATS_OK || s == NATS_NOT_YET_CONNECTED) return {};
  return fail(Errc::io_error, "cannot connect to the NATS broker at " + options.servers + ": " + describe(s));
}

void Connection::close() {
  if (!nc_) return;
  natsConnection_Close(nc_);  // flushes what was published
  {
    // Callbacks (disconnected, closed) still queued refer to this object.
    std::unique_lock lock(closed_mutex_);
    closed_cv_.wait_for(lock, std::chrono::seconds(2), [this] { return closed_; });
  }
  natsConnection_Destroy(nc_);
  nc_ = nullptr;
}

Connection::~Connection() { close(); }

}  // namespace mimic::net::nats_detail
#endif  // MIMIC_WITH_NATS
