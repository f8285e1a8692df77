// Texture coordinates with the mesh topology (kCapMeshUv): the codec's texture section, its
// checks, and the server sending it to the subscribers that agreed it (a plain topology to the
// others, as before), over loopback.
#include <gtest/gtest.h>

#include "net_test_support.h"

namespace mimic::net::mesh_uv_test {
namespace {

using namespace mimic::net::test;

// A quad of two triangles whose vertex 0 sits on a seam: textured vertices 0 and 4 both copy it.
MeshTopology quad(uint16_t avatar, uint8_t lod) {
  MeshTopology t{avatar, lod, 4, {0, 1, 2, 0, 2, 3}};
  t.uv_source = {0, 1, 2, 3, 0};
  t.uvs = {{0, 0}, {1, 0}, {1, 1}, {0, 1}, {1, 0.5f}};
  t.uv_indices = {0, 1, 2, 4, 2, 3};
  return t;
}

Bytes textured_packet(const MeshTopology& t) {
  Bytes b(mesh_topology_packet_bytes(t.indices.size(), t.uvs.size()));
  EXPECT_EQ(encode_mesh_topology_with_uvs(t, b), b.size());
  return b;
}

TEST(MeshUv, TheTextureSectionRoundTrips) {
  const MeshTopology t = quad(4, 1);
  const Bytes b = textured_packet(t);
  MeshTopology d;
  ASSERT_EQ(decode_mesh_topology(b, d), Reject::ok);
  EXPECT_EQ(d.indices, t.indices);
  EXPECT_EQ(d.uv_source, t.uv_source);
  EXPECT_EQ(d.uv_indices, t.uv_indices);
  ASSERT_EQ(d.uvs.size(), t.uvs.size());
  for (size_t i = 0; i < t.uvs.size(); ++i) EXPECT_EQ(d.uvs[i], t.uvs[i]);  // floats, bit for bit

  // The plain encoding is the version-1 packet, and decodes with no texture fields left over.
  Bytes plain(mesh_topology_packet_bytes(t.indices.size()));
  ASSERT_EQ(encode_mesh_topology(t, plain), plain.size());
  ASSERT_EQ(decode_mesh_topology(plain, d), Reject::ok);
  EXPECT_TRUE(d.uvs.empty() && d.uv_source.empty() && d.uv_indices.empty());

  // Every strict prefix longer than the plain part, and any trailing byte, is refused.
  for (size_t n = plain.size() + 1; n < b.size(); ++n) {
    Bytes cut(b.begin(), b.begin() + long(n));
    cut[4] = uint8_t(n - kHeaderBytes);  // the header says what is there: the body is short
    cut[5] = uint8_t((n - kHeaderBytes) >> 8);
    EXPECT_NE(decode_mesh_topology(cut, d), Reject::ok) << n;
  }
  Bytes longer = b;
  longer.push_back(0);
  longer[4] = uint8_t(longer.size() - kHeaderBytes);
  EXPECT_EQ(decode_mesh_topology(longer, d), Reject::malformed);
}

TEST(MeshUv, ATextureThatDisagreesWithItsTopologyIsMalformed) {
  MeshTopology d;
  MeshTopology t = quad(1, 0);
  t.uv_source[4] = 1;  // corner 3 copies vertex 1, where the triangle has vertex 0
  EXPECT_EQ(decode_mesh_topology(textured_packet(t), d), Reject::malformed);
  t = quad(1, 0);
  t.uv_source[2] = 9;  // past the skin's vertices
  EXPECT_EQ(decode_mesh_topology(textured_packet(t), d), Reject::malformed);
  t = quad(1, 0);
  t.uv_indices[5] = 5;  // past the textured vertices
  EXPECT_EQ(decode_mesh_topology(textured_packet(t), d), Reject::malformed);
  for (float bad : {-0.1f, 1.5f, std::nanf("")}) {
    t = quad(1, 0);
    t.uvs[3].y = bad;
    EXPECT_EQ(decode_mesh_topology(textured_packet(t), d), Reject::malformed) << bad;
  }
  t = quad(1, 0);
  t.uvs.pop_back();  // fields of different sizes: the encoder refuses
  Bytes b(256);
  EXPECT_EQ(encode_mesh_topology_with_uvs(t, b), 0u);
}

TEST(MeshUv, SubscribersThatAgreedGetTheTextureOthersThePlainTopology) {
  ServerThread st;
  ClientOptions o;
  o.connect = st.endpoint();
  o.role = Role::subscriber;
  o.mesh_lod = 1;
  auto c = Client::connect(o);
  ASSERT_TRUE(c) << c.error().what();
  auto thin = std::move(*c);
  EXPECT_TRUE(thin->negotiated_capabilities() & kCapMeshUv);
  // A subscriber of before texture coordinates: mesh frames, no kCapMeshUv.
  RawPeer old(st.port());
  Hello h;
  h.role = Role::subscriber;
  h.capabilities = kCapPose | kCapMesh;
  h.mesh_lod = 1;
  h.name = "old-viewer";
  Bytes hb(kMaxHelloBytes);
  hb.resize(encode_hello(h, hb));
  ASSERT_TRUE(old.send(hb));

  const uint16_t id = st.call([&] { return *st.server().add_avatar("local", 52, "model"); });
  ASSERT_TRUE(pump({thin.get()}, [&] { return thin->avatars().size() == 1; }));
  const MeshTopology topo = quad(id, 1);
  ASSERT_TRUE(st.call([&] { return st.server().set_mesh_topology(topo).has_value(); }));
  const std::vector<glm::vec3> positions = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}};
  Bytes frame(mesh_packet_bytes(4));
  ASSERT_GT(encode_mesh({id, 1, 1, wall_clock_us()}, positions, frame), 0u);
  EXPECT_EQ(st.call([&] { return st.server().publish_mesh(id, 1, frame); }), Reject::ok);
  ASSERT_TRUE(pump({thin.get()}, [&] { return thin->stats().mesh_frames == 1; }));
  const RemoteAvatar& a = thin->avatars().begin()->second;
  EXPECT_EQ(a.mesh_indices, topo.indices);
  EXPECT_EQ(a.mesh_uv_source, topo.uv_source);
  EXPECT_EQ(a.mesh_uv_indices, topo.uv_indices);
  ASSERT_EQ(a.mesh_uvs.size(), topo.uvs.size());
  EXPECT_EQ(a.mesh_uvs[4], topo.uvs[4]);

  // The old subscriber's MESH_TOPOLOGY is the plain packet its strict decoder takes.
  Bytes stream;
  bool seen = false;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(10);
  while (!seen && std::chrono::steady_clock::now() < deadline && !old.closed()) {
    const Bytes more = old.read(0.2, 1 << 20);
    stream.insert(stream.end(), more.begin(), more.end());
    for (size_t at = 0; at + kHeaderBytes <= stream.size() && !seen;) {
      Header hd;
      ASSERT_EQ(decode_header(std::span<const uint8_t>(stream).subspan(at), hd), Reject::ok);
      const size_t size = kHeaderBytes + hd.payload_bytes;
      if (at + size > stream.size()) break;
      if (hd.type == MsgType::mesh_topology) {
        seen = true;
        EXPECT_EQ(size, mesh_topology_packet_bytes(topo.indices.size()));
        MeshTopology d;
        ASSERT_EQ(decode_mesh_topology(std::span<const uint8_t>(stream).subspan(at, size), d), Reject::ok);
        EXPECT_TRUE(d.uvs.empty());
      }
      at += size;
    }
  }
  EXPECT_TRUE(seen) << "no topology for the old subscriber";
}

}  // namespace
}  // namespace mimic::net::mesh_uv_test
