#include "mimic/net/scene_connection.h"

#include "embedded_relay.h"
#include "mimic/net/nats.h"

namespace mimic::net {

Result<std::unique_ptr<Client>> open_scene_connection(const ClientOptions& options) {
  if (!is_nats_url(options.connect)) return Client::connect(options);
  if (options.role != Role::subscriber)
    return fail(Errc::invalid_argument, "publishing into a NATS scene is mimic run --nats, not a client");
  auto relay = nats_detail::EmbeddedRelay::start(options.connect, options.udp);
  if (!relay) return tl::unexpected(relay.error());
  ClientOptions local = options;
  local.connect = (*relay)->endpoint();
  auto c = Client::connect(local);
  if (c) (*c)->hold(std::move(*relay));
  return c;
}

}  // namespace mimic::net
