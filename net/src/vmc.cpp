#include <utility>

#include "mimic/net/vmc.h"

#include <bit>
#include <boost/asio.hpp>
#include <cstring>

#include "mimic/core/host_port.h"

namespace mimic::net {

namespace asio = boost::asio;

struct VmcSender::Impl {
  struct Avatar {
    std::unique_ptr<VmcEncoder> encoder;
    asio::ip::udp::endpoint dest;
    double first_time_s = 0;
    bool started = false;
  };
  asio::io_context io{1};
  asio::ip::udp::socket sock{io};
  asio::ip::address addr;
  uint16_t base_port = 0;
  std::vector<Avatar> avatars;
  std::vector<uint8_t> buf;
};

VmcSender::VmcSender(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
VmcSender::~VmcSender() = default;

Result<std::unique_ptr<VmcSender>> VmcSender::open(const std::string& host_port) {
  auto hp = split_host_port(host_port);
  if (!hp) return tl::unexpected(hp.error());
  auto impl = std::make_unique<Impl>();
  boost::system::error_code ec;
  auto addr = asio::ip::make_address(hp->host, ec);
  if (ec) {
    asio::ip::udp::resolver resolver(impl->io);
    auto results = resolver.resolve(hp->host, std::to_string(hp->port), ec);
    if (ec || results.empty()) return fail(Errc::not_found, "cannot resolve '" + hp->host + "'");
    addr = results.begin()->endpoint().address();
  }
  impl->addr = addr;
  impl->base_port = hp->port;
  impl->sock.open(addr.is_v4() ? asio::ip::udp::v4() : asio::ip::udp::v6(), ec);
  if (ec) return fail(Errc::io_error, "cannot open a UDP socket: " + ec.message());
  impl->sock.non_blocking(true, ec);
  impl->buf.reserve(4096);
  impl->avatars.reserve(64);
  return std::unique_ptr<VmcSender>(new VmcSender(std::move(impl)));
}

Status VmcSender::add_avatar(const rig::Skeleton& skeleton) {
  const size_t i = impl_->avatars.size();
  if (i >= 64) return fail(Errc::out_of_range, "VMC: at most 64 avatars");
  if (impl_->base_port + i > 65535)
    return fail(Errc::out_of_range, "VMC: avatar " + std::to_string(i) + " would need port " +
                                        std::to_string(impl_->base_port + i) + " (avatar i goes to port + i)");
  Impl::Avatar a;
  a.encoder = std::make_unique<VmcEncoder>(skeleton);
  a.dest = asio::ip::udp::endpoint(impl_->addr, static_cast<uint16_t>(impl_->base_port + i));
  impl_->avatars.push_back(std::move(a));
  return {};
}

size_t VmcSender::avatar_count() const { return impl_->avatars.size(); }

size_t VmcSender::send(size_t avatar, const rig::Pose& pose, double capture_time_s) {
  if (avatar >= impl_->avatars.size()) return 0;
  Impl::Avatar& a = impl_->avatars[avatar];
  if (!a.started) {
    a.started = true;
    a.first_time_s = capture_time_s;
  }
  const VmcBundles b = a.encoder->encode(pose, capture_time_s - a.first_time_s, impl_->buf);
  size_t sent = 0, begin = 0;
  for (size_t i = 0; i < b.count; ++i) {
    boost::system::error_code ec;
    const size_t n = impl_->sock.send_to(asio::buffer(impl_->buf.data() + begin, b.end[i] - begin), a.dest, 0, ec);
    if (ec) return 0;
    sent += n;
    begin = b.end[i];
  }
  return sent;
}

}  // namespace mimic::net
