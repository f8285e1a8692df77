// A TCP listener as Mimic's servers open one: the address reusable across a restart (the old
// socket may linger in TIME_WAIT), the OS's largest backlog.
#pragma once

#include <boost/asio/ip/tcp.hpp>

namespace mimic::net::detail {

inline boost::system::error_code listen_tcp(boost::asio::ip::tcp::acceptor& acceptor,
                                            const boost::asio::ip::tcp::endpoint& at) {
  boost::system::error_code ec;
  acceptor.open(at.protocol(), ec);
  if (!ec) acceptor.set_option(boost::asio::ip::tcp::acceptor::reuse_address(true), ec);
  if (!ec) acceptor.bind(at, ec);
  if (!ec) acceptor.listen(boost::asio::socket_base::max_listen_connections, ec);
  return ec;
}

}  // namespace mimic::net::detail
