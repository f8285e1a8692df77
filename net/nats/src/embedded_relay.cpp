#include "embedded_relay.h"

namespace mimic::net::nats_detail {

Result<std::shared_ptr<EmbeddedRelay>> EmbeddedRelay::start(std::string_view target, bool udp) {
  auto t = parse_nats_target(target);
  if (!t) return tl::unexpected(t.error());
  auto r = std::make_shared<EmbeddedRelay>();
  ServerOptions so;
  so.listen = "127.0.0.1:0";
  so.udp = udp;
  auto s = Server::create(so);
  if (!s) return tl::unexpected(s.error());
  r->server_ = std::move(*s);
  NatsOptions no;
  no.servers = t->servers;
  no.scene = t->scene;
  no.name = "mimic viewer";
  nats_credentials_from_env(no);
  auto f = NatsSceneFeed::create(no, *r->server_);
  if (!f) return tl::unexpected(f.error());
  r->feed_ = std::move(*f);
  r->thread_ = std::thread([srv = r->server_.get()] { srv->run(); });
  return r;
}

EmbeddedRelay::~EmbeddedRelay() {
  if (thread_.joinable()) {
    server_->stop();
    thread_.join();
  }
  feed_.reset();
}

}  // namespace mimic::net::nats_detail
