// A VRPN tracker remote: reads a `vrpn_Tracker` device (and optionally a `vrpn_Button` device)
// from any VRPN server — OptiTrack Motive, Vicon Tracker, VRPN's own vrpn_server driving Polhemus,
// ART, Vive, InterSense…, or `mimic run --vrpn` — speaking VRPN 07 as VRPN's own clients do
// (docs/vrpn.md, docs/hardware.md):
//   - "DEVICE@HOST[:PORT]": the client listens on a TCP port of its own and asks the server, by a
//     UDP datagram to PORT, to connect back; reports then come by UDP (low latency);
//   - "DEVICE@tcp://HOST[:PORT]": the client connects to the TCP port; everything comes on TCP.
// After the cookies, each side describes its senders and message types; the client sends its
// UDP port (not in tcp:// mode) and pings once a second, as vrpn_BaseClass does.
//
// Driven from the caller's loop: poll() does the socket work that is due without blocking and
// returns the reports that arrived; it never allocates or throws once created. A server that
// goes silent (no message for `silent_after_s`) or away is dropped, and the remote connects again
// by itself every `retry_after_s`; the link state says where it is. IPv4, as VRPN.
#pragma once

#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include <glm/glm.hpp>
#include <glm/gtc/quaternion.hpp>

#include "mimic/core/clock.h"
#include "mimic/core/result.h"

namespace mimic::net {

struct VrpnAddress {
  std::string device;  // the sender name, e.g. "Tracker0", "RigidBody1"
  std::string host;
  uint16_t port = 3883;  // VRPN's usual port
  bool tcp_only = false;

  std::string text() const;  // as VRPN writes it
};

// "Tracker0@localhost", "Tracker0@host:3883", "Tracker0@tcp://host:3883". Fails (naming the
// text) without a device or host, or with a bad port.
Result<VrpnAddress> parse_vrpn_address(std::string_view text);

// One `vrpn_Tracker Pos_Quat` report, in the server's frame and units (VRPN fixes neither).
struct VrpnReport {
  int32_t device = 0;  // 0: Options::tracker.device; i > 0: Options::more_trackers[i - 1]
  int32_t sensor = 0;
  glm::dvec3 position{0.0};
  glm::dquat orientation{1, 0, 0, 0};
  double capture_unix_s = 0;  // the server's timestamp: when the sample was taken
  double received_s = 0;      // the caller's clock when it arrived
};

// One `vrpn_Button Change`.
struct VrpnButtonEvent {
  int32_t button = 0;
  bool pressed = false;
  double received_s = 0;
};

enum class VrpnLink : uint8_t {
  waiting,      // before the next attempt
  connecting,   // TCP connect, or waiting for the server to call back
  handshaking,  // cookies
  connected,    // descriptions exchanged, reports flowing
};
const char* vrpn_link_name(VrpnLink link);

struct VrpnClientStats {
  uint64_t connects = 0;  // handshakes completed
  uint64_t drops = 0;     // connections lost (closed, broken, silent, bad cookie)
  uint64_t reports = 0;   // Pos_Quat reports of the device
  uint64_t buttons = 0;   // button changes of the button device
  uint64_t udp_datagrams = 0;
  uint64_t malformed = 0;  // bad lengths, bad reports, datagrams from elsewhere
  uint64_t pongs = 0;
};

class VrpnTrackerRemote {
 public:
  struct Options {
    VrpnAddress tracker;
    // More tracker devices on the same server (OptiTrack Motive and Vicon Tracker serve each rigid
    // body as a device of its own, sensor 0).
    std::vector<std::string> more_trackers;
    std::string button_device;  // on the same server; empty: none
    double silent_after_s = 3.0;
    double retry_after_s = 1.0;
  };
  // Resolves the host (the one blocking step: at setup, never in poll()). Fails on a host that
  // does not resolve.
  static Result<std::unique_ptr<VrpnTrackerRemote>> create(const Options& options,
                                                           std::shared_ptr<const Clock> clock = nullptr);
  ~VrpnTrackerRemote();
  VrpnTrackerRemote(const VrpnTrackerRemote&) = delete;
  VrpnTrackerRemote& operator=(const VrpnTrackerRemote&) = delete;

  // Socket work that is due; the reports and button changes that arrived, at most the spans'
  // sizes (more stay queued for the next poll). Returns the number of reports.
  size_t poll(std::span<VrpnReport> reports, std::span<VrpnButtonEvent> buttons, size_t& button_count);

  VrpnLink link() const;
  const VrpnClientStats& stats() const;
  const std::string& last_error() const;  // why the last connection ended or failed
  const Options& options() const;
  double last_heard_s() const;  // the caller's clock when the server last sent anything

 private:
  struct Impl;
  explicit VrpnTrackerRemote(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace mimic::net
