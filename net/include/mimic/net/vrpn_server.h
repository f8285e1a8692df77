// A VRPN server: Mimic's avatars as vrpn_Tracker devices, in VRPN's own wire protocol (07.35:
// the "vrpn: ver. 07.35" cookie over TCP, sender and type descriptions, tracker reports over UDP
// when the client offers its UDP port), so VR applications and engine plugins that read
// trackers over VRPN (vrpn_Tracker_Remote, `vrpn_print_devices Avatar0@host:port`) read Mimic.
//
// Devices, for avatar i (in the order add_avatar was called):
//   Avatar<i>   one sensor per joint of the avatar's skeleton, sensor number = joint index
//               (skeleton order; docs/vrpn.md lists Mimic's default skeleton): the joint's
//               world position (metres) and world orientation, in Mimic's world frame (+Y up,
//               the body faces +Z, its left is +X).
//   Sensors<i>  the tracker samples the avatar's solver used this frame (after the sensor
//               filters), sensor number = Mimic's sensor id, in the tracker's reference frame.
// Each report is a "vrpn_Tracker Pos_Quat" message stamped with the frame's capture time.
//
// Connections. Both ways VRPN clients connect are served: the default one (the client sends a
// UDP datagram "<its address> <its TCP port>" to the server's port and the server connects back
// over TCP; Mimic connects back only to the address the datagram came from) and "tcp://"
// (the client connects to the server's TCP port). Reports go over UDP to the port a client
// announced in its UDP description, in datagrams of at most 1,472 bytes (VRPN's UDP buffer),
// and otherwise over TCP. Clients' pings are answered with pongs. At most 16 clients.
//
// Threading and the realtime loop: one thread calls everything. poll() does the network
// bookkeeping without blocking; send_pose()/send_sample()/flush() never allocate or throw (all
// buffers are sized at create/add_avatar). A client whose TCP buffer is full misses frames (latest
// wins), it never holds the loop up.
#pragma once

#include <cstdint>
#include <memory>
#include <span>
#include <string>

#include <glm/glm.hpp>
#include <glm/gtc/quaternion.hpp>

#include "mimic/rig/skeleton.h"
#include "mimic/core/result.h"

namespace mimic::net {

struct VrpnServerStats {
  uint64_t connections = 0;   // clients that completed the handshake
  uint64_t lob_requests = 0;  // UDP connection requests received
  uint64_t refused = 0;       // bad cookies, malformed requests, no free slot
  uint64_t reports = 0;       // Pos_Quat messages sent (all clients)
  uint64_t udp_datagrams = 0;
  uint64_t frames_dropped = 0;  // frames a client missed because its TCP buffer was full
  uint64_t pongs = 0;
  int clients = 0;  // connected now
};

class VrpnServer {
 public:
  // `listen` is "[HOST:]PORT" (HOST defaults to 127.0.0.1; VRPN's usual port is 3883; 0 picks a
  // free one). Binds TCP and UDP on it. Fails when the address is bad or the port is taken.
  static Result<std::unique_ptr<VrpnServer>> create(const std::string& listen);
  ~VrpnServer();
  VrpnServer(const VrpnServer&) = delete;
  VrpnServer& operator=(const VrpnServer&) = delete;

  // Setup only (before clients connect): devices Avatar<i> and Sensors<i> for the next avatar.
  Status add_avatar(const rig::Skeleton& skeleton);
  size_t avatar_count() const;
  uint16_t port() const;
  std::string endpoint() const;  // "host:port"

  // Accepts connections, runs handshakes, answers pings, sends what TCP could not take at once.
  void poll();
  // Avatar `avatar`'s joints (forward kinematics of `pose`) as Avatar<i>'s reports, captured at
  // `unix_time_s`.
  void send_pose(size_t avatar, const rig::Pose& pose, double unix_time_s);
  // One sample as a report of Sensors<i>; goes out with the next flush().
  void send_sample(size_t avatar, int32_t sensor, const glm::vec3& position_m, const glm::quat& orientation,
                   double unix_time_s);
  // Sends what send_pose/send_sample queued.
  void flush();

  VrpnServerStats stats() const;

 private:
  struct Impl;
  explicit VrpnServer(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace mimic::net
