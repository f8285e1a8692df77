// Where the pipeline's frames go: every output (the scene served here, a remote scene, a NATS
// broker, VMC, VRPN — and the browser and engine sinks to come) is a PoseSink with one calling
// convention. The pipeline encodes each pose frame once and hands every sink the same FrameOut;
// it holds a list of sinks and knows none of them by name.
//
// Per pass of the loop a sink sees: begin(poses), send() per avatar with a new frame, end(poses)
// (where batched frames leave the sockets); then begin(meshes), send_mesh() for the avatars
// whose mesh it asked for, end(meshes). Between passes, poll() (the network's bookkeeping).
//
// Stale repeats (a silent source's last pose sent again, flagged stale, Pipeline::kStaleRepeat_s
// apart) reach only the sinks whose forwards_stale_repeats() is true:
//   scene server, remote publisher, NATS: yes — their frames carry the stale flag, so a
//     subscriber tells a dead source from a quiet one;
//   VMC, VRPN: no — neither protocol has a stale flag, so a repeat would pass for a live frame;
//     going quiet is how their receivers learn the source stopped.
// New sinks say which they are here.
//
// Realtime rules: send(), send_mesh(), begin() and end() run inside Pipeline::tick(): they never
// allocate, throw or block. add_avatar() and add_mesh() are setup and may allocate.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "mimic/avatar/mesh.h"
#include "mimic/rig/skeleton.h"
#include "mimic/core/result.h"
#include "mimic/devices/sample.h"

namespace mimic::net {
class Server;
class Client;
class VmcSender;
class NatsPublisher;
class VrpnServer;
struct PoseHeader;
struct MeshTopology;
}  // namespace mimic::net

namespace mimic::service {

// An avatar joining the scene (setup).
struct AvatarJoin {
  size_t index = 0;  // the pipeline's avatar index: FrameOut::avatar
  const std::string& name;
  const rig::Skeleton& skeleton;
  const std::string& model_bytes;  // the body model's compact JSON, sent to subscribers on join
  // The avatar's id in pose and mesh frames. A sink that numbers avatars itself (the scene
  // server) sets it; the pipeline asks sinks in list order, so such a sink goes first.
  uint16_t wire_id = 0;
};

// One avatar's new pose, as every sink receives it.
struct FrameOut {
  size_t avatar = 0;                               // the pipeline's avatar index
  const net::PoseHeader& header;                   // as encoded in `packet` (avatar = the wire id)
  const rig::Pose& pose;                           // in the scene's world frame
  std::span<const uint8_t> packet;                 // the pose frame, encoded once; empty if the encoder refused it
  std::span<const devices::SensorSample> samples;  // the tracker samples the pose was solved from
  double time_s = 0;                               // capture time, seconds since the Unix epoch (header.time_us)
  bool stale_repeat = false;                       // the last pose again: the source is silent
};

// One avatar's deformed mesh (at the deformer's LOD), encoded once for the sinks that asked.
struct MeshOut {
  size_t avatar = 0;
  uint8_t lod = 0;
  const avatar::Mesh& mesh;
  std::span<const uint8_t> packet;  // the mesh frame
};

class PoseSink {
 public:
  enum class Phase { poses, meshes };
  virtual ~PoseSink() = default;
  virtual const char* name() const noexcept = 0;
  virtual bool forwards_stale_repeats() const noexcept = 0;  // see the table above

  virtual Status add_avatar(AvatarJoin& join) = 0;
  // The avatar's mesh topology (fixed for the run) and its rest frame, announced at setup.
  virtual Status add_mesh(size_t /*avatar*/, const net::MeshTopology& /*topology*/,
                          std::span<const uint8_t> /*rest_frame*/) {
    return {};
  }

  virtual void begin(Phase) noexcept {}
  // False when the frame could not be sent (counted in Pipeline::send_failures()).
  virtual bool send(const FrameOut& frame) noexcept = 0;
  virtual void end(Phase) noexcept {}
  // Whether someone downstream wants avatar `avatar`'s mesh frames at `lod` now.
  virtual bool wants_mesh(size_t /*avatar*/, uint8_t /*lod*/) const noexcept { return false; }
  virtual bool send_mesh(const MeshOut& /*mesh*/) noexcept { return true; }

  // Between passes: what the network has for this sink, without blocking. An error ends the run
  // (the remote scene we publish into closed the session).
  virtual Status poll() { return {}; }
};

using SinkList = std::vector<std::unique_ptr<PoseSink>>;

// The sinks of the network outputs; each refers to an output the caller owns and keeps alive.
std::unique_ptr<PoseSink> make_server_sink(net::Server& server);        // host the scene here
std::unique_ptr<PoseSink> make_publisher_sink(net::Client& publisher);  // publish into a remote scene
std::unique_ptr<PoseSink> make_nats_sink(net::NatsPublisher& nats);     // every avatar through a broker
std::unique_ptr<PoseSink> make_vmc_sink(net::VmcSender& vmc);           // avatar i to the sender's avatar i
std::unique_ptr<PoseSink> make_vrpn_sink(net::VrpnServer& vrpn);        // joints and samples as trackers

}  // namespace mimic::service
