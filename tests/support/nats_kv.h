// A bare NATS client for tests that look at the broker directly: what the model bucket holds,
// a model left behind as by a dead publisher, a heartbeat sent by hand, what another user may
// try. Needs the broker transport (mimic::nats).
#pragma once

#include <nats/nats.h>

#include <string>
#include <vector>

namespace mimic::test {

class NatsProbe {
 public:
  // `url` may carry a user's credentials (NatsBroker::url_as): the probe then has that user's
  // permissions, and a refused put or delete fails after a second (no answer comes).
  explicit NatsProbe(const std::string& url) {
    jsOptions jo;
    jsOptions_Init(&jo);
    jo.Wait = 1000;
    ok_ = natsConnection_ConnectTo(&nc_, url.c_str()) == NATS_OK && natsConnection_JetStream(&js_, nc_, &jo) == NATS_OK;
  }
  ~NatsProbe() {
    if (sub_) natsSubscription_Destroy(sub_);
    if (kv_) kvStore_Destroy(kv_);
    if (js_) jsCtx_Destroy(js_);
    if (nc_) natsConnection_Destroy(nc_);
  }
  NatsProbe(const NatsProbe&) = delete;
  NatsProbe& operator=(const NatsProbe&) = delete;
  bool ok() const { return ok_; }

  // Opens the bucket (creating it, no TTL, when `create`).
  bool open_bucket(const std::string& bucket, bool create = false) {
    if (kv_) return true;
    if (js_KeyValue(&kv_, js_, bucket.c_str()) == NATS_OK) return true;
    kv_ = nullptr;
    if (!create) return false;
    kvConfig cfg;
    kvConfig_Init(&cfg);
    cfg.Bucket = bucket.c_str();
    cfg.History = 1;
    return js_CreateKeyValue(&kv_, js_, &cfg) == NATS_OK;
  }
  bool put(const std::string& key, const std::vector<uint8_t>& value) {
    uint64_t rev = 0;
    return kv_ && kvStore_Put(&rev, kv_, key.c_str(), value.data(), int(value.size())) == NATS_OK;
  }
  bool remove(const std::string& key) { return kv_ && kvStore_Delete(kv_, key.c_str()) == NATS_OK; }
  // True while the bucket holds a value for `key`.
  bool holds(const std::string& key) {
    kvEntry* e = nullptr;
    const natsStatus s = kv_ ? kvStore_Get(&e, kv_, key.c_str()) : NATS_ERR;
    if (e) kvEntry_Destroy(e);
    return s == NATS_OK;
  }
  bool publish(const std::string& subject, const std::string& data) {
    return natsConnection_Publish(nc_, subject.c_str(), data.data(), int(data.size())) == NATS_OK &&
           natsConnection_FlushTimeout(nc_, 2000) == NATS_OK;
  }
  // Messages on `subject` (wildcards allowed) from now on, read one at a time by next().
  bool subscribe(const std::string& subject) {
    return natsConnection_SubscribeSync(&sub_, nc_, subject.c_str()) == NATS_OK &&
           natsConnection_FlushTimeout(nc_, 2000) == NATS_OK;
  }
  // The next message's payload; false on timeout.
  bool next(std::vector<uint8_t>& payload, int timeout_ms = 5000) {
    natsMsg* m = nullptr;
    if (!sub_ || natsSubscription_NextMsg(&m, sub_, timeout_ms) != NATS_OK) return false;
    const auto* d = reinterpret_cast<const uint8_t*>(natsMsg_GetData(m));
    payload.assign(d, d + natsMsg_GetDataLength(m));
    natsMsg_Destroy(m);
    return true;
  }

 private:
  natsConnection* nc_ = nullptr;
  jsCtx* js_ = nullptr;
  kvStore* kv_ = nullptr;
  natsSubscription* sub_ = nullptr;
  bool ok_ = false;
};

}  // namespace mimic::test
