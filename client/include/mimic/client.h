// Mimic client library: subscribe to a Mimic scene (mimic run, or any server speaking
// docs/protocol.md) and get every avatar's joints, solved and posed, without knowing Mimic's
// body model or wire format. The one public header of libmimic_client; standard C++17 only.
//
//   find_package(Mimic REQUIRED)                 # or: pkg-config --cflags --libs mimic
//   target_link_libraries(app PRIVATE Mimic::client)
//
//   std::string error;
//   auto sub = mimic::client::Subscriber::connect({"127.0.0.1:7777"}, &error);
//   sub->on_frame = [](const mimic::client::Avatar& a) { ... a.joints[j].position_m ... };
//   while (sub->poll(&error)) { ... }            // or run_for(seconds, &error)
//
// Frames: metres, +Y up, the body faces +Z, its left is +X (Mimic's world). Orientations are
// unit quaternions (x, y, z, w), world_from_joint. A Subscriber is used from one thread; its
// callbacks run inside poll()/run_for() on that thread. After any cut (the connection dropped, the
// server restarted or timed this client out while it was stopped) it reconnects and resumes in
// the background, with the newest frames; poll() fails only when the session ended for good
// (refused: wrong secret, no common protocol version).
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#if defined(_WIN32)
#define MIMIC_CLIENT_API
#else
#define MIMIC_CLIENT_API __attribute__((visibility("default")))
#endif

namespace mimic::client {

struct Vec3 {
  float x = 0, y = 0, z = 0;
};
struct Quat {
  float x = 0, y = 0, z = 0, w = 1;
};
struct Vec2 {
  float u = 0, v = 0;
};

struct Joint {
  std::string name;  // e.g. "pelvis", "l_elbow" (docs/body-model.md)
  int parent = -1;   // index in Avatar::joints, -1 for the root
  Vec3 position_m;   // world position of the joint centre
  Quat orientation;  // world_from_joint rotation
};

struct Avatar {
  uint16_t id = 0;            // scene-wide id
  std::string name;           // as published, e.g. "avatar1"
  std::vector<Joint> joints;  // parents before children
  std::vector<std::string> dof_names;
  std::vector<float> dof_rad;  // the pose frame's joint angles, in dof_names order
  Vec3 root_position_m;
  Quat root_orientation;
  uint32_t sequence = 0;  // of the latest pose frame
  uint64_t time_us = 0;   // its capture time, µs since the Unix epoch (publisher's clock)
  bool stale = false;     // the publisher's trackers had no fresh data
  bool has_pose = false;  // false until the first pose frame (joints at rest until then)
  uint64_t frames = 0;    // pose frames received
  uint64_t lost = 0;      // frames superseded before they reached us (latest wins)
};

// The deformed skin of an avatar at one LOD, as the server deforms it (mesh frames, for clients
// that draw Mimic's body without deforming it themselves). The index array and the texture
// coordinates come once per topology; each frame moves the vertices. Buffers are sized when the
// topology arrives and reused for every frame: receiving a frame does not allocate.
//
// With texture coordinates (from a server that sends them: capability bit 5, docs/protocol.md),
// the mesh comes with its seams split, as a vertex buffer needs it: a point where u wraps round
// a limb or two parts meet is one vertex per side, each with its own (u, v) and the same
// position and normal (normals are computed on the welded skin, so no seam shows in shading).
struct Mesh {
  uint16_t avatar = 0;
  int lod = 0;
  std::vector<uint32_t> indices;  // triangles, counter-clockwise seen from outside
  std::vector<Vec3> positions_m;  // world positions (16-bit quantised in the frame's box)
  std::vector<Vec3> normals;      // unit, area-weighted over each vertex's triangles
  // Per vertex (u around a part, v along it), each part its own square of [0, 1]² (the skin's
  // texture layout); empty when the server sends none. Fixed until the topology changes.
  std::vector<Vec2> uvs;
  uint32_t sequence = 0;  // of the latest mesh frame
  uint64_t time_us = 0;   // its capture time, µs since the Unix epoch
  uint64_t frames = 0;    // mesh frames received
};

// How the connection has fared so far.
struct Link {
  bool connected = false;
  uint64_t cuts = 0;     // times the connection of an established session was cut
  uint64_t outages = 0;  // cuts after which frames came again
  double outage_s = 0;   // time without frames over those (last frame before to first after)
  uint64_t lost = 0;     // frames missed by sequence, all avatars, across cuts and restarts
};

struct Options {
  std::string server = "127.0.0.1:7777";  // HOST:PORT
  std::string name = "mimic-client";      // shown in the server's session list
  bool udp = false;                       // pose frames as UDP datagrams when offered
  // Also receive the deformed skin at this LOD (0 finest .. 3), or -1 for joints only. A server
  // that does not deform at that LOD refuses the session and says which LODs it serves.
  int mesh_lod = -1;
  double connect_timeout_s = 3.0;
};

class MIMIC_CLIENT_API Subscriber {
 public:
  // Connects and completes the handshake (blocking, up to connect_timeout_s). nullptr on
  // failure, with the reason in *error when error is not null.
  static std::unique_ptr<Subscriber> connect(const Options& options, std::string* error = nullptr);
  ~Subscriber();
  Subscriber(const Subscriber&) = delete;
  Subscriber& operator=(const Subscriber&) = delete;

  std::function<void(const Avatar&)> on_avatar;  // an avatar joined (or a new body revision)
  std::function<void(const Avatar&)> on_frame;   // a new pose: joints are posed
  std::function<void(uint16_t id)> on_removed;   // an avatar left
  std::function<void(const Mesh&)> on_mesh;      // a new mesh frame (Options::mesh_lod)

  // Handles what the network has, without blocking. false: the session ended (reason in *error).
  bool poll(std::string* error = nullptr);
  // Handles the network for `seconds`, sleeping while nothing arrives.
  bool run_for(double seconds, std::string* error = nullptr);

  std::vector<uint16_t> avatar_ids() const;
  const Avatar* avatar(uint16_t id) const;  // nullptr when absent; valid until the next poll
  const Mesh* mesh(uint16_t id) const;      // nullptr before the first mesh frame; valid until the next poll
  Link link() const;

 private:
  struct Impl;
  explicit Subscriber(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

MIMIC_CLIENT_API const char* version();  // "0.1.0"

}  // namespace mimic::client
