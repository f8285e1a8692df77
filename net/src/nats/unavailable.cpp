// A build without the NATS client (MIMIC_WITH_NATS=OFF): the broker transport says so.
#if !MIMIC_WITH_NATS
#include "mimic/net/nats.h"

namespace mimic::net {

namespace {
Error unavailable() { return {Errc::unsupported, "this build has no NATS support (configure with -DMIMIC_WITH_NATS=ON)"}; }
}  // namespace

struct NatsPublisher::Impl {};
struct NatsSceneFeed::Impl {};

Result<std::unique_ptr<NatsPublisher>> NatsPublisher::create(const NatsOptions&) { return tl::unexpected(unavailable()); }
NatsPublisher::NatsPublisher(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
NatsPublisher::~NatsPublisher() = default;
Result<int> NatsPublisher::add_avatar(const std::string&, uint16_t, std::string) { return tl::unexpected(unavailable()); }
void NatsPublisher::publish_pose(int, std::span<const uint8_t>) noexcept {}
void NatsPublisher::begin_tick() noexcept {}
void NatsPublisher::end_tick() noexcept {}
Status NatsPublisher::add_mesh(int, const MeshTopology&) { return tl::unexpected(unavailable()); }
bool NatsPublisher::mesh_wanted(int) const noexcept { return false; }
void NatsPublisher::publish_mesh(int, std::span<const uint8_t>) noexcept {}
bool NatsPublisher::connected() const { return false; }
NatsLinkState NatsPublisher::link_state() const noexcept { return {}; }
std::string NatsPublisher::connected_url() const { return {}; }
NatsLinkStats NatsPublisher::stats() const { return {}; }
std::string NatsPublisher::key(int) const { return {}; }

Result<std::unique_ptr<NatsSceneFeed>> NatsSceneFeed::create(const NatsOptions&, Server&) {
  return tl::unexpected(unavailable());
}
NatsSceneFeed::NatsSceneFeed(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
NatsSceneFeed::~NatsSceneFeed() = default;
bool NatsSceneFeed::connected() const { return false; }
NatsLinkState NatsSceneFeed::link_state() const noexcept { return {}; }
std::string NatsSceneFeed::connected_url() const { return {}; }
NatsLinkStats NatsSceneFeed::stats() const { return {}; }

}  // namespace mimic::net
#endif
