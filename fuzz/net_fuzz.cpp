// libFuzzer target for the scene protocol: arbitrary bytes as a TCP stream (PacketReader) and
// every packet through every decoder. Decoders must refuse, never crash or read out of bounds.
#include <cstddef>
#include <cstdint>
#include <cstring>

#include "mimic/net/frame_codec.h"
#include "mimic/net/pose_stream.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace mimic::net;
  PacketReader reader(kMaxPacketBytes, 256);
  // Feed in two uneven pieces so partial headers and bodies are exercised.
  const size_t cut = size ? data[0] % (size + 1) : 0;
  const size_t pieces[2][2] = {{0, cut}, {cut, size}};
  Hello hello;
  Welcome welcome;
  RejectMsg reject;
  AvatarModel model;
  PoseHeader pose_header;
  mimic::rig::Pose pose;
  MeshTopology topology;
  MeshFrameHeader mesh_header;
  std::vector<glm::vec3> positions;
  uint16_t avatar = 0;
  UdpRegister token;
  std::vector<SceneEntry> scene;
  static LeanPoseState lean;  // large: not on the stack
  lean = LeanPoseState{};
  for (const auto& piece : pieces) {
    const size_t n = piece[1] - piece[0];
    if (n) {
      auto space = reader.write_space(n);
      std::memcpy(space.data(), data + piece[0], n);
      reader.commit(n);
    }
    for (;;) {
      std::span<const uint8_t> p;
      if (reader.next(p) != Reject::ok || p.empty()) break;
      (void)decode_hello(p, hello);
      (void)decode_welcome(p, welcome);
      (void)decode_reject(p, reject);
      (void)decode_avatar_model(p, model);
      (void)decode_avatar_removed(p, avatar);
      (void)decode_udp_register(p, token);
      (void)decode_scene(p, scene);
      (void)decode_pose(p, pose_header, pose);
      (void)decode_key_request(p, avatar);
      (void)decode_lean_pose(p, lean, pose_header, pose);  // on top of whatever state came before
      (void)decode_mesh_topology(p, topology);
      (void)decode_mesh(p, mesh_header, positions);
    }
  }
  // And the raw bytes as one whole packet.
  const std::span<const uint8_t> whole(data, size);
  (void)decode_pose(whole, pose_header, pose);
  (void)decode_lean_pose(whole, lean, pose_header, pose);  // a datagram on the subscriber's socket
  (void)decode_udp_register(whole, token);                 // what arrives on the server's UDP socket
  (void)decode_hello(whole, hello);
  (void)decode_avatar_model(whole, model);
  return 0;
}
