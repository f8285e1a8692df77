// The public Server API over ServerImpl; the server's parts live in server/ (server_impl.h lists them).
#include "mimic/net/server.h"

#include <algorithm>
#include <thread>
#include <utility>

#include "mimic/core/host_port.h"
#include "mimic/core/process_limits.h"
#include "server/server_impl.h"
#include "tcp_listen.h"

namespace mimic::net {

// ---- Server -----------------------------------------------------------------------------------

Server::Server(std::unique_ptr<ServerImpl> impl) : impl_(std::move(impl)) {}

Server::~Server() {
  if (!impl_) return;
  boost::system::error_code ec;
  impl_->acceptor.close(ec);
  impl_->accept_timer.cancel();
  impl_->udp_sock.close(ec);
  impl_->deferred.clear();
  for (auto& s : std::vector<std::shared_ptr<Session>>(impl_->sessions)) s->close(true);
  impl_->housekeeping.cancel();
  impl_->io.restart();
  impl_->io.poll();
  impl_->sessions.clear();
}

Result<std::unique_ptr<Server>> Server::create(const ServerOptions& options) {
  auto hp = split_host_port(options.listen);
  if (!hp) return tl::unexpected(hp.error());
  auto impl = std::make_unique<ServerImpl>();
  impl->opt = options;
  boost::system::error_code ec;
  // "localhost" is the loopback address (not a name to resolve: it must not be anything else).
  const std::string host = hp->host == "localhost" ? "127.0.0.1" : hp->host;
  const auto addr = asio::ip::make_address(host, ec);
  if (ec) return fail(Errc::invalid_argument, "bad listen address '" + hp->host + "': " + ec.message());
  impl->loopback = addr.is_loopback();
  if (!impl->loopback && options.secret.empty())
    return fail(Errc::invalid_argument,
                "serving on " + options.listen +
                    " exposes the scene beyond this machine: give publishers a shared secret (--secret)");
  const tcp::endpoint ep(addr, hp->port);
  ec = detail::listen_tcp(impl->acceptor, ep);
  if (ec) return fail(Errc::io_error, "cannot listen on " + options.listen + ": " + ec.message());
  if (options.udp) {
    // Same address and port as the listener. If another program holds the UDP port, the server
    // runs without it and does not offer the capability.
    const udp::endpoint uep(addr, impl->acceptor.local_endpoint().port());
    boost::system::error_code uec;
    impl->udp_sock.open(uep.protocol(), uec);
    if (!uec) impl->udp_sock.bind(uep, uec);
    if (!uec) impl->udp_sock.non_blocking(true, uec);
    impl->udp_on = !uec;
    if (!uec) impl->udp_local = impl->udp_sock.local_endpoint(uec);
    if (uec) impl->udp_sock.close(uec);
  }
  impl->fanout_threads = options.fanout_threads > 0 ? options.fanout_threads
                                                    : int(std::clamp(std::thread::hardware_concurrency(), 1u, 4u));
  // Each session holds a descriptor and the process needs others (listeners, logs, the broker,
  // devices): sessions stop short of the descriptor limit, so accept() keeps working and a
  // client over it is told "server full" instead of the accept loop failing with EMFILE.
  const size_t fds = descriptor_limit();
  const size_t spare = std::max<size_t>(64, fds / 8);
  impl->opt.max_sessions = std::min(options.max_sessions, fds > spare + 16 ? fds - spare : size_t(16));
  impl->stats.max_sessions_effective = impl->opt.max_sessions;
  impl->avatars.emplace_back();  // id 0 is never used
  impl->lanes.resize(size_t(impl->fanout_threads));
  impl->reserve_fanout();
  impl->start_accept();
  if (impl->udp_on) impl->start_udp_receive();
  impl->schedule_housekeeping();
  return std::unique_ptr<Server>(new Server(std::move(impl)));
}

uint16_t Server::port() const { return impl_->acceptor.local_endpoint().port(); }
bool Server::udp() const { return impl_->udp_on; }
int Server::fanout_threads() const { return impl_->fanout_threads; }

std::string Server::endpoint() const {
  const auto ep = impl_->acceptor.local_endpoint();
  return ep.address().to_string() + ":" + std::to_string(ep.port());
}

Result<uint16_t> Server::add_avatar(const std::string& name, uint16_t dof_count, std::string model_bytes) {
  return impl_->new_avatar(name, dof_count, std::move(model_bytes), nullptr);
}

void Server::remove_avatar(uint16_t avatar) { impl_->drop_avatar(avatar); }

Status Server::update_avatar_model(uint16_t avatar, uint16_t dof_count, std::string model_bytes) {
  Avatar* a = impl_->avatar(avatar);
  if (!a || a->owner) return fail(Errc::not_found, "no local avatar " + std::to_string(avatar));
  if (dof_count > kMaxPoseDofs) return fail(Errc::out_of_range, "too many DOFs for a pose frame");
  if (model_bytes.size() > kMaxModelBytes) return fail(Errc::out_of_range, "body model too large");
  AvatarModel m;
  m.dof_count = dof_count;
  m.model_bytes = std::move(model_bytes);
  m.name = a->name;
  if (!impl_->model_fits(avatar_model_packet_bytes(m), a))
    return fail(Errc::out_of_range, "the server's models would pass its memory bound");
  impl_->update_model(*a, m);
  return {};
}

Reject Server::publish_pose(uint16_t avatar, std::span<const uint8_t> packet) {
  Avatar* a = impl_->avatar(avatar);
  if (!a) return Reject::unexpected;
  Header h;
  if (const Reject e = decode_header(packet, h); e != Reject::ok) return e;
  if (h.type != MsgType::pose || packet.size() != pose_packet_bytes(a->dof_count)) return Reject::malformed;
  const Reject e = impl_->accept_pose(*a, packet);
  if (e != Reject::ok) impl_->stats.rejected[static_cast<size_t>(e)]++;
  return e;
}

uint8_t Server::mesh_lods_wanted(uint16_t avatar) const {
  uint8_t mask = 0;
  for (const auto& s : impl_->sessions)
    if (s->active && s->role == Role::subscriber && s->mesh_lod < kMaxLods) mask |= uint8_t(1u << s->mesh_lod);
  return impl_->avatar(avatar) ? mask : 0;
}

Status Server::set_mesh_topology(const MeshTopology& topology) {
  Avatar* a = impl_->avatar(topology.avatar);
  if (!a) return fail(Errc::not_found, "no avatar " + std::to_string(topology.avatar));
  if (topology.lod >= kMaxLods) return fail(Errc::out_of_range, "LOD must be below 8");
  switch (impl_->set_topology(*a, topology)) {
    case Reject::ok: return {};
    case Reject::unavailable: return fail(Errc::out_of_range, "mesh frames would pass the server's memory bound");
    default: return fail(Errc::out_of_range, "mesh too large");
  }
  return {};
}

Reject Server::publish_mesh(uint16_t avatar, uint8_t lod, std::span<const uint8_t> packet) {
  Avatar* a = impl_->avatar(avatar);
  if (!a || lod >= kMaxLods) return Reject::unexpected;
  return impl_->accept_mesh(*a, lod, packet);
}

void Server::run_until(std::chrono::steady_clock::time_point deadline) {
  if (impl_->io.stopped()) impl_->io.restart();
  impl_->start_deferred();
  impl_->io.run_until(deadline);
}

void Server::poll() {
  if (impl_->io.stopped()) impl_->io.restart();
  impl_->start_deferred();
  // io.poll() would run until nothing is ready, and a peer that keeps work ready (a flood, a
  // completion that re-arms at once) would keep it there: a budget of completions and time.
  const auto& o = impl_->opt;
  const auto deadline = Clock::now() + std::chrono::microseconds(std::max(o.poll_budget_us, 1));
  for (int n = 0;; ++n) {
    if (n >= std::max(o.poll_max_handlers, 1) || ((n & 15) == 15 && Clock::now() >= deadline)) {
      impl_->stats.poll_budget_hit++;
      return;
    }
    if (impl_->io.poll_one() == 0) return;
  }
}

void Server::run() {
  if (impl_->io.stopped()) impl_->io.restart();
  impl_->start_deferred();
  auto guard = asio::make_work_guard(impl_->io);
  impl_->io.run();
}

void Server::stop() { impl_->io.stop(); }

void Server::begin_batch() { impl_->batching = true; }

void Server::end_batch() {
  impl_->batching = false;
  impl_->flush_subscribers();
}

void Server::dispatch(std::function<void()> fn) { asio::post(impl_->io, std::move(fn)); }

const ServerStats& Server::stats() const {
  // Counted down by the packets' deleters, whenever the last write holding one lets go.
  impl_->stats.model_bytes_held = *impl_->model_bytes_held;
  impl_->fold_lanes();
  return impl_->stats;
}

Server::FanoutTimes Server::fanout_times() const {
  FanoutTimes t;
  t.count = impl_->fanouts;
  const size_t n = std::min<uint64_t>(impl_->fanouts, impl_->fanout_us.size());
  if (n == 0) return t;
  std::vector<float> v(impl_->fanout_us.begin(), impl_->fanout_us.begin() + long(n));
  auto at = [&](double q) {
    const size_t k = std::min(n - 1, size_t(q * double(n - 1) + 0.5));
    std::nth_element(v.begin(), v.begin() + long(k), v.end());
    return double(v[k]);
  };
  t.p50_us = at(0.50);
  t.p99_us = at(0.99);
  return t;
}

std::vector<SessionInfo> Server::sessions() const {
  std::vector<SessionInfo> v;
  for (const auto& s : impl_->sessions) {
    if (!s->active) continue;
    v.push_back({s->id, s->role, s->name, s->frames_out, s->frames_dropped, s->rejected, s->udp_ready});
  }
  return v;
}

}  // namespace mimic::net
