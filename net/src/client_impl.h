// The client's state, shared by client.cpp (connection, handshake, packets, the public API) and
// client_link.cpp (datagrams, keep-alive, the stall watch, and what a cut costs).
#pragma once

#include <array>
#include <utility>

#include <boost/asio.hpp>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "mimic/net/client.h"
#include "mimic/net/frame_codec.h"

namespace mimic::net {

namespace client_detail {

namespace asio = boost::asio;
using tcp = asio::ip::tcp;
using udp = asio::ip::udp;
using Clock = std::chrono::steady_clock;

inline constexpr size_t kMaxSlots = 16;

inline Clock::duration seconds(double s) {
  return std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(s));
}

struct PublishedAvatar {
  bool live = false;
  std::string name;
  uint16_t dof_count = 0;
  std::vector<uint8_t> model_packet;
  std::array<uint8_t, kMaxDatagramBytes> pose{};
  size_t pose_size = 0;
  bool pending = false;
};

// An avatar of a session that ended (the scene came back as a new session after a cut): what its
// next frames are measured against, so the frames missed in the cut count as lost.
struct DepartedAvatar {
  uint16_t id = 0;
  std::string name;
  uint16_t dof_count = 0;
  size_t model_hash = 0;
  uint32_t sequence = 0;
  uint64_t time_us = 0;
  Clock::time_point left{};
};

}  // namespace client_detail

struct Client::Impl {
  using Clock = client_detail::Clock;
  using tcp = client_detail::tcp;
  using udp = client_detail::udp;

  // What Client::hold keeps alive (e.g. the relay serving this client): destroyed after
  // everything below it.
  std::vector<std::shared_ptr<void>> held;
  Client* owner = nullptr;
  ClientOptions opt;
  boost::asio::io_context io{1};
  std::optional<tcp::socket> sock;
  tcp::endpoint endpoint;
  PacketReader reader{kMaxPacketBytes};
  bool connected = false;
  bool handshake_done = false;
  std::optional<Error> fatal;  // the session is over for good
  bool dropped = false;        // connection lost; may resume
  SessionToken token;
  uint32_t caps = 0;
  uint64_t generation = 0;  // handlers of an old socket ignore themselves
  ClientStats stats;
  std::map<uint16_t, RemoteAvatar> avatars;
  std::array<client_detail::PublishedAvatar, client_detail::kMaxSlots> published;
  rig::Pose scratch_pose;
  MeshTopology scratch_topology;

  std::vector<uint8_t> out, control;
  bool writing = false;

  // Pose frames as datagrams: one socket for the client's life, registered with the session
  // token (again after every resume, and every second to keep NAT mappings open).
  std::optional<udp::socket> usock;
  std::array<uint8_t, kMaxDatagramBytes> uin{};
  udp::endpoint ufrom;
  bool udp_ready = false;
  uint64_t udp_nonce = 0;  // the server's last answer: echoed to prove we receive at this address
  boost::asio::steady_timer udp_timer{io};
  // A session that says nothing is closed by the server's idle timeout; a PING every 2 s keeps a
  // quiet subscriber (or a publisher whose source is silent) alive.
  boost::asio::steady_timer keepalive_timer{io};
  void keepalive();
  // The latest datagram frame of each avatar whose model is still on its way (bounded).
  std::map<uint16_t, std::vector<uint8_t>> early;
  static constexpr size_t kMaxEarly = 64;
  void start_udp();
  void register_udp();
  void udp_receive();
  size_t drain_udp();
  void on_pose(std::span<const uint8_t> p, uint64_t now_us, bool datagram);

  boost::asio::steady_timer retry_timer{io};
  boost::asio::steady_timer handshake_timer{io};
  bool connecting = false;             // a connection attempt (TCP or handshake) is under way
  int failures = 0;                    // consecutive failed attempts
  std::optional<Error> connect_error;  // why the last attempt failed
  Clock::time_point welcome_at{};      // when the current session's WELCOME came
  int short_sessions = 0;              // consecutive sessions cut within a second of WELCOME

  // The stall watch (subscribers): a timer notes every 100 ms that it ran. A handler that finds
  // it has not run for opt.stall_resync_s knows this thread was not driving the client (the
  // process was stopped, the caller busy): what the socket buffers hold is that old, so the
  // client drops it and reconnects (resuming) to get the newest frames instead.
  boost::asio::steady_timer watch_timer{io};
  Clock::time_point watch_seen{};
  bool watching = false;
  void start_watch();
  bool resync_if_stalled();

  // What cuts cost: the time without frames from the last frame before a cut to the first after
  // it, and the frames missed by sequence (also across a new session: `departed`).
  Clock::time_point last_frame_at{};
  std::optional<Clock::time_point> outage_from;
  uint64_t lost_at_cut = 0;
  std::vector<client_detail::DepartedAvatar> departed;
  static constexpr size_t kMaxDeparted = 4096;
  static constexpr auto kDepartedFor = std::chrono::minutes(10);
  void cut(std::string why);
  void remember_departed();
  void remember_departed(const RemoteAvatar& a);
  void carry_over(RemoteAvatar& a);
  void count_carried_loss(RemoteAvatar& a, const PoseHeader& h);
  void frames_flow_again(Clock::time_point now);

  void start_connection();
  void connect_failed(Errc code, std::string message);
  void schedule_retry();
  void read();
  void on_packet(std::span<const uint8_t> p);
  void on_welcome(const Welcome& w);
  void on_reject(const RejectMsg& r);
  void queue_control(std::span<const uint8_t> bytes) { control.insert(control.end(), bytes.begin(), bytes.end()); }
  void flush();
  void lose_connection();
  void end(Errc code, std::string message) {
    if (!fatal) fatal = Error{code, std::move(message)};
    lose_connection();
  }
  Status status() const {
    if (fatal) return tl::unexpected(*fatal);
    return {};
  }
};

}  // namespace mimic::net
