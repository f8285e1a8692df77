// Broker connection setup shared by the publisher and the relay feed.
#include "nats_connection.h"

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
std::string owned_key(const std::string& publisher_token, const std::string& key) {
  return publisher_token + "." + key;
}
bool is_owned_key(std::string_view text) {
  const size_t dot = text.find('.');
  if (dot == 0 || dot == std::string_view::npos || dot > 64 || text.size() != dot + 17) return false;
  for (size_t i = 0; i < dot; ++i) {
    const char c = text[i];
    if (!((c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_' || c == '-'))
      return false;
  }
  for (size_t i = dot + 1; i < text.size(); ++i)
    if (!((text[i] >= '0' && text[i] <= '9') || (text[i] >= 'a' && text[i] <= 'f'))) return false;
  return true;
}
std::string mesh_subject(const std::string& scene, const std::string& owned, unsigned lod) {
  return "mimic." + scene + ".mesh." + owned + "." + std::to_string(lod);
}
std::string mesh_want_subject(const std::string& scene, const std::string& owned) {
  return "mimic." + scene + ".want." + owned;
}
std::string_view last_token(std::string_view subject) {
  const size_t dot = subject.rfind('.');
  return dot == std::string_view::npos ? subject : subject.substr(dot + 1);
}
std::string status_subject(const std::string& scene, const std::string& publisher_token) {
  return "mimic." + scene + ".status." + publisher_token;
}

int64_t monotonic_us() noexcept {
  return std::chrono::duration_cast<std::chrono::microseconds>(std::chrono::steady_clock::now().time_since_epoch())
      .count();
}

void Connection::set_up(bool up) noexcept {
  const int64_t now = monotonic_us();
  if (up) {
    if (const int64_t since = down_since_us_.exchange(0); since != 0) last_outage_us_ = now - since;
  } else if (up_.load()) {
    down_since_us_ = now;
  }
  up_.store(up, std::memory_order_release);
}

NatsLinkState Connection::state() const noexcept {
  NatsLinkState s;
  s.connected = connected();
  s.disconnects = disconnects_;
  const int64_t since = down_since_us_;
  s.down_s = !s.connected && since != 0 ? double(monotonic_us() - since) * 1e-6 : 0;
  s.last_outage_s = double(last_outage_us_.load()) * 1e-6;
  return s;
}

void Connection::disconnected_cb(natsConnection*, void* self) {
  auto* a = static_cast<Anchor*>(self);
  std::lock_guard anchor(a->mutex);
  if (Connection* c = a->owner) {
    c->disconnects_++;
    c->set_up(false);
  }
}

void Connection::reconnected_cb(natsConnection*, void* self) {
  auto* a = static_cast<Anchor*>(self);
  std::lock_guard anchor(a->mutex);
  if (Connection* c = a->owner) {
    c->reconnects_++;
    c->set_up(true);
    if (c->on_reconnected) c->on_reconnected();
  }
}

void Connection::error_cb(natsConnection*, natsSubscription*, natsStatus s, void* self) {
  auto* a = static_cast<Anchor*>(self);
  std::lock_guard anchor(a->mutex);
  if (Connection* c = a->owner) c->set_error(natsStatus_GetText(s));
}

void Connection::closed_cb(natsConnection*, void* self) {
  auto* a = static_cast<Anchor*>(self);
  bool orphaned = false;
  {
    std::lock_guard anchor(a->mutex);
    if (Connection* c = a->owner) {
      c->up_ = false;
      std::lock_guard lock(c->closed_mutex_);
      c->closed_ = true;
      c->closed_cv_.notify_all();
    }
    a->closed = true;
    orphaned = a->orphaned;
  }
  if (orphaned) delete a;
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
  // Without the credentials an address may carry (nats://USER:PASSWORD@HOST:PORT): this is shown.
  std::string url = buf;
  if (const size_t scheme = url.find("://"), at = url.rfind('@');
      scheme != std::string::npos && at != std::string::npos && at > scheme)
    url.erase(scheme + 3, at - scheme - 2);
  return url;
}

// Addresses as shown in messages: without the USER:PASSWORD@ an address may carry.
std::string redact_urls(std::string_view servers) { return nats_display_servers(servers); }

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
      msg.append(redact_urls(u)).append("' is not a nats://HOST:PORT address");
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
  // The wait above comes only after every server of the list failed once; the jitter on top
  // stays small so that a failover never waits long for it.
  if (s == NATS_OK) s = natsOptions_SetReconnectJitter(o, 50, 200);
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
  // A connection opened before is closed first: its client destroyed, its anchor either freed
  // here (its closed callback came) or handed to that callback.
  close();
  delete anchor_;
  {
    std::lock_guard lock(closed_mutex_);
    closed_ = false;
  }
  anchor_ = new Anchor;
  anchor_->owner = this;
  if (s == NATS_OK) s = natsOptions_SetDisconnectedCB(o, disconnected_cb, anchor_);
  if (s == NATS_OK) s = natsOptions_SetReconnectedCB(o, reconnected_cb, anchor_);
  if (s == NATS_OK) s = natsOptions_SetErrorHandler(o, error_cb, anchor_);
  if (s == NATS_OK) s = natsOptions_SetClosedCB(o, closed_cb, anchor_);
  if (s != NATS_OK) return fail(Errc::invalid_argument, "nats options: " + describe(s));

  s = natsConnection_Connect(&nc_, o);
  if (s == NATS_OK) {
    set_up(true);
    return {};
  }
  const std::string why = describe(s);
  const bool refused = s == NATS_CONNECTION_AUTH_FAILED || s == NATS_NOT_PERMITTED ||
                       why.find("uthorization") != std::string::npos || why.find("uthentication") != std::string::npos;
  if (refused)
    return fail(Errc::invalid_argument, "the NATS broker at " + redact_urls(options.servers) +
                                            " refused the credentials (" + why +
                                            "); set MIMIC_NATS_USER and MIMIC_NATS_PASSWORD, or MIMIC_NATS_TOKEN");
  if (s != NATS_NO_SERVER && s != NATS_TIMEOUT && s != NATS_IO_ERROR)
    return fail(Errc::io_error, "cannot connect to the NATS broker at " + redact_urls(options.servers) + ": " + why);
  // Nobody answers yet: keep trying in the background; the callback reports the connect.
  set_error("broker unreachable: " + why);
  nc_ = nullptr;
  down_since_us_ = monotonic_us();
  natsOptions_SetRetryOnFailedConnect(o, true, reconnected_cb, anchor_);
  s = natsConnection_Connect(&nc_, o);
  if (s == NATS_OK || s == NATS_NOT_YET_CONNECTED) return {};
  return fail(Errc::io_error,
              "cannot connect to the NATS broker at " + redact_urls(options.servers) + ": " + describe(s));
}

void Connection::close() {
  if (!nc_) return;
  natsConnection_Close(nc_);  // flushes what was published
  {
    // Callbacks (disconnected, closed) still queued refer to this object.
    std::unique_lock lock(closed_mutex_);
    closed_cv_.wait_for(lock, std::chrono::seconds(2), [this] { return closed_; });
  }
  bool orphaned = false;
  {
    // From here on the client's callbacks find no owner. Not closed yet (a loaded machine, a
    // broker going down mid-close): the closed callback frees the anchor when it comes.
    std::lock_guard anchor(anchor_->mutex);
    anchor_->owner = nullptr;
    orphaned = anchor_->orphaned = !anchor_->closed;
  }
  if (orphaned) anchor_ = nullptr;
  natsConnection_Destroy(nc_);
  nc_ = nullptr;
}

Connection::~Connection() {
  close();
  delete anchor_;
}

}  // namespace mimic::net::nats_detail
