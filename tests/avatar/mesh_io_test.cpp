#include "mimic/avatar/mesh_io.h"

#include <gtest/gtest.h>

#include <cstring>
#include <filesystem>
#include <limits>
#include <random>

#include <unistd.h>

#include <nlohmann/json.hpp>

#include "mimic/core/file.h"
#include "test_data.h"

namespace mimic::avatar::mesh_io_test {
namespace {

namespace fs = std::filesystem;

// Unit cube split into two parts ("bottom" = the 2 triangles at y = 0, "sides_top" = the rest),
// with per-vertex normals pointing away from the centre.
Mesh two_part_cube() {
  Mesh m;
  for (int i = 0; i < 8; ++i)
    m.positions.push_back({float(i & 1) * 0.5f, float((i >> 1) & 1) * 0.25f - 0.125f, float((i >> 2) & 1) * 0.1f});
  for (const auto& p : m.positions) m.normals.push_back(glm::normalize(p - glm::vec3(0.25f, 0, 0.05f)));
  // Counter-clockwise seen from outside; bottom (y low) first.
  const uint32_t quads[6][4] = {{0, 1, 5, 4}, {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}, {0, 2, 3, 1}, {4, 5, 7, 6}};
  for (const auto& q : quads) {
    m.indices.insert(m.indices.end(), {q[0], q[1], q[2], q[0], q[2], q[3]});
  }
  m.parts = {{"bottom", 0, 2}, {"sides_top", 2, 10}};
  return m;
}

fs::path temp_dir() { return fs::temp_directory_path() / ("mimic_mesh_io_" + std::to_string(::getpid())); }

// Removes this process's scratch files when the test binary exits.
struct TempDirCleaner {
  ~TempDirCleaner() {
    std::error_code ec;
    fs::remove_all(temp_dir(), ec);
  }
} temp_dir_cleaner;

std::string temp_path(const std::string& name) {
  fs::create_directories(temp_dir());
  return (temp_dir() / name).string();
}

void expect_same_mesh(const Mesh& a, const Mesh& b, bool normals) {
  ASSERT_EQ(a.positions.size(), b.positions.size());
  for (size_t i = 0; i < a.positions.size(); ++i) EXPECT_EQ(a.positions[i], b.positions[i]) << i;
  EXPECT_EQ(a.indices, b.indices);
  ASSERT_EQ(a.parts.size(), b.parts.size());
  for (size_t i = 0; i < a.parts.size(); ++i) {
    EXPECT_EQ(a.parts[i].name, b.parts[i].name);
    EXPECT_EQ(a.parts[i].first_triangle, b.parts[i].first_triangle);
    EXPECT_EQ(a.parts[i].triangle_count, b.parts[i].triangle_count);
  }
  if (normals) {
    ASSERT_EQ(a.normals.size(), b.normals.size());
    for (size_t i = 0; i < a.normals.size(); ++i) EXPECT_LT(glm::length(a.normals[i] - b.normals[i]), 1e-6f) << i;
  }
}

TEST(MeshIo, ObjRoundTripKeepsPositionsIndicesPartsNormals) {
  const Mesh m = two_part_cube();
  const std::string path = temp_path("cube.obj");
  ASSERT_TRUE(write_mesh(m, path));
  auto back = read_mesh(path);
  ASSERT_TRUE(back) << back.error().what();
  expect_same_mesh(m, *back, true);
  auto text = read_file(path);
  ASSERT_TRUE(text);
  EXPECT_NE(text->find("\ng bottom\n"), std::string::npos);
  EXPECT_NE(text->find("\nvn "), std::string::npos);
  EXPECT_NE(text->find("\no mimic_body\n"), std::string::npos);
}

TEST(MeshIo, PlyRoundTripKeepsPositionsIndicesPartsNormals) {
  const Mesh m = two_part_cube();
  const std::string path = temp_path("cube.ply");
  ASSERT_TRUE(write_mesh(m, path));
  auto back = read_mesh(path);
  ASSERT_TRUE(back) << back.error().what();
  expect_same_mesh(m, *back, true);
  auto bytes = read_file(path);
  ASSERT_TRUE(bytes);
  const std::string header = bytes->substr(0, bytes->find("end_header\n") + 11);
  EXPECT_NE(header.find("format binary_little_endian 1.0\n"), std::string::npos);
  EXPECT_NE(header.find("comment part 0 bottom\n"), std::string::npos);
  EXPECT_NE(header.find("property list uchar int vertex_indices\nproperty ushort part\n"), std::string::npos);
  // 8 vertices * 6 floats + 12 faces * (1 + 12 + 2) bytes follow the header exactly.
  EXPECT_EQ(bytes->size() - header.size(), 8u * 24 + 12u * 15);
}

TEST(MeshIo, GlbRoundTripKeepsPositionsIndicesPartsNormals) {
  const Mesh m = two_part_cube();
  const std::string path = temp_path("cube.glb");
  ASSERT_TRUE(write_mesh(m, path));
  auto back = read_mesh(path);
  ASSERT_TRUE(back) << back.error().what();
  expect_same_mesh(m, *back, true);
}

TEST(MeshIo, RoundTripWithoutNormalsStaysWithoutNormals) {
  Mesh m = two_part_cube();
  m.normals.clear();
  for (const char* ext : {".obj", ".ply", ".glb"}) {
    auto bytes = ext == std::string(".obj")   ? encode_obj(m)
                 : ext == std::string(".ply") ? encode_ply(m)
                                              : encode_glb(m);
    ASSERT_TRUE(bytes) << ext;
    auto back = ext == std::string(".obj")   ? parse_obj(*bytes)
                : ext == std::string(".ply") ? parse_ply(*bytes)
                                             : parse_glb(*bytes);
    ASSERT_TRUE(back) << ext << " " << back.error().what();
    EXPECT_TRUE(back->normals.empty()) << ext;
    expect_same_mesh(m, *back, false);
  }
}

uint32_t u32_at(const std::string& s, size_t at) {
  uint32_t v;
  std::memcpy(&v, s.data() + at, 4);
  return v;
}

TEST(MeshIo, GlbStructureFollowsTheSpec) {
  const Mesh m = two_part_cube();
  auto bytes = encode_glb(m);
  ASSERT_TRUE(bytes);
  const std::string& b = *bytes;
  ASSERT_GE(b.size(), 28u);
  EXPECT_EQ(b.substr(0, 4), "glTF");
  EXPECT_EQ(u32_at(b, 4), 2u);
  EXPECT_EQ(u32_at(b, 8), b.size());
  EXPECT_EQ(b.size() % 4, 0u);
  const uint32_t json_len = u32_at(b, 12);
  EXPECT_EQ(u32_at(b, 16), 0x4E4F534Au);
  EXPECT_EQ(json_len % 4, 0u);
  const std::string text = b.substr(20, json_len);
  // Padding of the JSON chunk is spaces (the spec's requirement), not NULs.
  EXPECT_EQ(text.find('\0'), std::string::npos);
  const size_t bin_at = 20 + json_len;
  const uint32_t bin_len = u32_at(b, bin_at);
  EXPECT_EQ(u32_at(b, bin_at + 4), 0x004E4942u);
  EXPECT_EQ(bin_len % 4, 0u);
  EXPECT_EQ(bin_at + 8 + bin_len, b.size());

  const auto doc = nlohmann::json::parse(text);
  EXPECT_EQ(doc["asset"]["version"], "2.0");
  EXPECT_EQ(doc["asset"]["generator"], "Mimic");
  EXPECT_EQ(doc["buffers"].size(), 1u);
  const size_t buffer_len = doc["buffers"][0]["byteLength"];
  EXPECT_LE(buffer_len, bin_len);
  EXPECT_GT(buffer_len + 4, bin_len);  // padding is less than 4 bytes
  for (const auto& v : doc["bufferViews"]) {
    const size_t off = v.value("byteOffset", 0), len = v["byteLength"];
    EXPECT_EQ(off % 4, 0u);
    EXPECT_LE(off + len, buffer_len);
  }
  ASSERT_EQ(doc["nodes"].size(), 1u);
  EXPECT_EQ(doc["nodes"][0]["name"], "mimic_body");
  ASSERT_EQ(doc["meshes"].size(), 1u);
  const auto& prims = doc["meshes"][0]["primitives"];
  ASSERT_EQ(prims.size(), 2u);
  const auto& accs = doc["accessors"];
  size_t index_total = 0;
  for (size_t i = 0; i < prims.size(); ++i) {
    EXPECT_EQ(prims[i]["attributes"]["POSITION"], prims[0]["attributes"]["POSITION"]);  // shared
    EXPECT_EQ(prims[i]["attributes"]["NORMAL"], prims[0]["attributes"]["NORMAL"]);
    EXPECT_EQ(prims[i]["mode"], 4);
    const auto& ia = accs[prims[i]["indices"].get<size_t>()];
    EXPECT_EQ(ia["componentType"], 5125);
    EXPECT_EQ(ia["type"], "SCALAR");
    EXPECT_EQ(ia.value("byteOffset", 0) % 4, 0);
    index_total += ia["count"].get<size_t>();
    const auto& view = doc["bufferViews"][ia["bufferView"].get<size_t>()];
    EXPECT_EQ(view["target"], 34963);
    EXPECT_LE(ia.value("byteOffset", size_t{0}) + ia["count"].get<size_t>() * 4, view["byteLength"].get<size_t>());
  }
  EXPECT_EQ(prims[0]["extras"]["name"], "bottom");
  EXPECT_EQ(index_total, m.indices.size());
  const auto& pos = accs[prims[0]["attributes"]["POSITION"].get<size_t>()];
  EXPECT_EQ(pos["count"], 8);
  EXPECT_EQ(pos["componentType"], 5126);
  EXPECT_EQ(pos["type"], "VEC3");
  EXPECT_FLOAT_EQ(pos["min"][0].get<float>(), 0.0f);
  EXPECT_FLOAT_EQ(pos["max"][0].get<float>(), 0.5f);
  EXPECT_FLOAT_EQ(pos["min"][1].get<float>(), -0.125f);
  EXPECT_FLOAT_EQ(pos["max"][1].get<float>(), 0.125f);
  EXPECT_FLOAT_EQ(pos["max"][2].get<float>(), 0.1f);
}

TEST(MeshIo, GlbLeavesOutEmptyPartsAndRejectsEmptyMesh) {
  Mesh m = two_part_cube();
  m.parts = {{"empty", 0, 0}, {"all", 0, 12}};
  auto bytes = encode_glb(m);
  ASSERT_TRUE(bytes);
  auto back = parse_glb(*bytes);
  ASSERT_TRUE(back);
  ASSERT_EQ(back->parts.size(), 1u);
  EXPECT_EQ(back->parts[0].name, "all");
  EXPECT_FALSE(encode_glb(Mesh{}));
}

TEST(MeshIo, WriteMeshRejectsUnknownExtensionAndBadMesh) {
  const Mesh m = two_part_cube();
  auto r = write_mesh(m, temp_path("cube.stl"));
  ASSERT_FALSE(r);
  EXPECT_EQ(r.error().code, Errc::unsupported);
  EXPECT_NE(r.error().message.find(".stl"), std::string::npos);
  Mesh bad = m;
  bad.indices[4] = 99;
  auto r2 = write_mesh(bad, temp_path("bad.obj"));
  ASSERT_FALSE(r2);
  EXPECT_EQ(r2.error().code, Errc::invalid_argument);
  EXPECT_FALSE(fs::exists(temp_path("bad.obj")));
  Mesh overlap = m;
  overlap.parts = {{"a", 0, 8}, {"b", 4, 8}};
  EXPECT_FALSE(write_mesh(overlap, temp_path("overlap.ply")));
}

TEST(MeshIo, PartNamesThatAreNotUtf8StillMakeValidGlb) {
  Mesh m = two_part_cube();
  m.parts[0].name = "bad\xff\xfename";
  auto bytes = encode_glb(m);
  ASSERT_TRUE(bytes);
  auto back = parse_glb(*bytes);
  ASSERT_TRUE(back) << back.error().what();
  EXPECT_EQ(back->parts[0].name, "bad\xEF\xBF\xBD\xEF\xBF\xBDname");  // U+FFFD twice
  // OBJ and PLY keep the bytes (minus control characters, which would break their lines).
  m.parts[1].name = "two\nlines";
  auto obj = parse_obj(*encode_obj(m));
  ASSERT_TRUE(obj);
  EXPECT_EQ(obj->parts[0].name, "bad\xff\xfename");
  EXPECT_EQ(obj->parts[1].name, "two_lines");
}

TEST(MeshIo, WriteMeshFillsPartGapsWithAMeshPart) {
  Mesh m = two_part_cube();
  m.parts = {{"middle", 4, 4}};
  auto back = parse_obj(*encode_obj(m));
  ASSERT_TRUE(back);
  ASSERT_EQ(back->parts.size(), 2u);  // the two gaps share the name "mesh", so they merge
  EXPECT_EQ(back->parts[0].name, "mesh");
  EXPECT_EQ(back->parts[0].triangle_count, 8u);
  EXPECT_EQ(back->parts[1].name, "middle");
}

TEST(MeshIo, ObjReaderHandlesEveryFaceForm) {
  const std::string text =
      "# comment\r\n"
      "mtllib x.mtl\r\n"
      "v 0 0 0\r\nv 1 0 0 1.0\r\nv 1 1 0\r\nv 0 1 0   # trailing comment\r\n"
      "vt 0 0\nvt 1 0\nvt 1 1\n"
      "vn 0 0 1\n"
      "s off\n"
      "o thing\n"
      "f 1 2 3\n"
      "g quad\n"
      "f 1/1 2/2 3/3 4/1\n"
      "g neg\n"
      "f -4//-1 -3//1 -2//1\n"
      "g full\n"
      "f 1/1/1 3/3/1 4/2/1\n"
      "g quad\n"
      "f 4 3 2 1 \n"
      "l 1 2\n";
  auto m = parse_obj(text);
  ASSERT_TRUE(m) << m.error().what();
  EXPECT_EQ(m->positions.size(), 4u);
  ASSERT_EQ(m->triangle_count(), 7u);
  // Parts in order of first appearance, "quad" gathered from both of its blocks.
  ASSERT_EQ(m->parts.size(), 4u);
  EXPECT_EQ(m->parts[0].name, "thing");
  EXPECT_EQ(m->parts[1].name, "quad");
  EXPECT_EQ(m->parts[1].triangle_count, 4u);
  EXPECT_EQ(m->parts[2].name, "neg");
  EXPECT_EQ(m->parts[3].name, "full");
  // Quad fan: (1,2,3), (1,3,4); the later quad gathered right after it.
  const std::vector<uint32_t> quad = {0, 1, 2, 0, 2, 3, 3, 2, 1, 3, 1, 0};
  EXPECT_EQ(std::vector<uint32_t>(m->indices.begin() + 3, m->indices.begin() + 15), quad);
  EXPECT_EQ(std::vector<uint32_t>(m->indices.begin() + 15, m->indices.begin() + 18), (std::vector<uint32_t>{0, 1, 2}));
  // Faces referenced normals, so every vertex has one.
  ASSERT_EQ(m->normals.size(), 4u);
  EXPECT_EQ(m->normals[0], glm::vec3(0, 0, 1));
}

TEST(MeshIo, ObjWithoutGroupsIsOnePart) {
  auto m = parse_obj("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
  ASSERT_TRUE(m);
  ASSERT_EQ(m->parts.size(), 1u);
  EXPECT_EQ(m->parts[0].name, "mesh");
  EXPECT_TRUE(m->normals.empty());
}

void expect_obj_error(const std::string& text, const std::string& where, const std::string& what) {
  auto m = parse_obj(text, "t.obj");
  ASSERT_FALSE(m) << text;
  EXPECT_EQ(m.error().code, Errc::parse_error);
  EXPECT_NE(m.error().message.find(where), std::string::npos) << m.error().message;
  EXPECT_NE(m.error().message.find(what), std::string::npos) << m.error().message;
}

TEST(MeshIo, ObjReaderNamesTheLineOfMalformedInput) {
  const std::string tri = "v 0 0 0\nv 1 0 0\nv 0 1 0\n";
  expect_obj_error(tri + "f 1 2\n", "t.obj:4:", "at least 3");
  expect_obj_error("v 0 0 0\nv 1 x 0\n", "t.obj:2:", "bad number 'x'");
  expect_obj_error("v 0 0\n", "t.obj:1:", "3 numbers");
  expect_obj_error(tri + "f 1 2 4\n", "t.obj:4:", "out of range");
  expect_obj_error(tri + "f 0 1 2\n", "t.obj:4:", "bad vertex index");
  expect_obj_error(tri + "f -4 1 2\n", "t.obj:4:", "before the first vertex");
  expect_obj_error(tri + "f 1//5 2 3\n", "t.obj:4:", "normal index 5");
  expect_obj_error(tri + "\n\nf 1/2/3/4 2 3\n", "t.obj:6:", "too many '/'");
  expect_obj_error("v nan 0 0\n", "t.obj:1:", "bad number");
  expect_obj_error(tri + "f 1 2 99999999999\n", "t.obj:4:", "");
}

TEST(MeshIo, PlyReaderReadsAsciiPolygonsAndNamesErrors) {
  const std::string ply =
      "ply\r\nformat ascii 1.0\r\ncomment part 7 torso\r\nelement vertex 4\r\n"
      "property double x\r\nproperty double y\r\nproperty double z\r\nproperty uchar red\r\n"
      "element face 1\r\nproperty list uchar uint vertex_index\r\nproperty int part\r\nend_header\r\n"
      "0 0 0 255\r\n1 0 0 0\r\n1 1 0 0\r\n0 1 0 0\r\n4 0 1 2 3 7\r\n";
  auto m = parse_ply(ply);
  ASSERT_TRUE(m) << m.error().what();
  EXPECT_EQ(m->positions.size(), 4u);
  EXPECT_EQ(m->indices, (std::vector<uint32_t>{0, 1, 2, 0, 2, 3}));
  ASSERT_EQ(m->parts.size(), 1u);
  EXPECT_EQ(m->parts[0].name, "torso");

  EXPECT_FALSE(parse_ply("plx\n"));
  EXPECT_FALSE(parse_ply("ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nend_header\n0\n"));
  auto bad_index = parse_ply(
      "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
      "element face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n");
  ASSERT_FALSE(bad_index);
  EXPECT_NE(bad_index.error().message.find("out of range"), std::string::npos);
  // Two vertex lists with different attributes would leave normals that do not match positions.
  auto two_lists = parse_ply(
      "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\n"
      "property float nx\nproperty float ny\nproperty float nz\n"
      "element vertex 1\nproperty float x\nproperty float y\nproperty float z\nend_header\n0 0 0 0 0 1\n1 0 0\n");
  ASSERT_FALSE(two_lists);
  EXPECT_NE(two_lists.error().message.find("line 10: a second vertex element"), std::string::npos)
      << two_lists.error().message;
}

TEST(MeshIo, TruncatedBinaryFilesFailCleanly) {
  const Mesh m = two_part_cube();
  for (auto encode : {encode_ply, encode_glb}) {
    const std::string full = *encode(m);
    for (size_t cut : {size_t{0}, size_t{5}, size_t{20}, full.size() / 2, full.size() - 3}) {
      const std::string part = full.substr(0, cut);
      auto r = encode == encode_ply ? parse_ply(part) : parse_glb(part);
      EXPECT_FALSE(r) << "cut at " << cut;
      if (!r) {
        EXPECT_EQ(r.error().code, Errc::parse_error);
      }
    }
  }
}

// Every finite float is a position some file can hold: the largest ones must survive each format
// (a reader's range check once stopped short of FLT_MAX and refused what a writer had written).
TEST(MeshIo, ExtremeFiniteValuesRoundTripInEveryFormat) {
  Mesh m = two_part_cube();
  const float big = std::numeric_limits<float>::max();
  m.positions[0] = {-big, big, -3.2e24f};
  m.positions[1] = {std::numeric_limits<float>::denorm_min(), -3.3895316e38f, 1e-38f};
  m.uvs.assign(m.positions.size(), glm::vec2(0.25f, 0.75f));
  m.uvs[2] = {big, -big};
  ASSERT_TRUE(validate_mesh(m));
  for (auto encode : {encode_obj, encode_ply, encode_glb}) {
    const auto bytes = encode(m);
    ASSERT_TRUE(bytes);
    auto r = encode == encode_obj ? parse_obj(*bytes) : encode == encode_ply ? parse_ply(*bytes) : parse_glb(*bytes);
    ASSERT_TRUE(r) << r.error().what();
    EXPECT_TRUE(validate_mesh(*r));
    ASSERT_EQ(r->positions.size(), m.positions.size());
    EXPECT_EQ(r->positions[0], m.positions[0]);
    EXPECT_EQ(r->positions[1], m.positions[1]);
    EXPECT_EQ(r->triangle_count(), m.triangle_count());
  }
}

TEST(MeshIo, NonFiniteValuesAreRejectedWithTheirIndex) {
  Mesh m = two_part_cube();
  m.positions[3].y = std::numeric_limits<float>::infinity();
  auto bad = validate_mesh(m);
  ASSERT_FALSE(bad);
  EXPECT_NE(bad.error().message.find("vertex 3"), std::string::npos) << bad.error().message;
  EXPECT_FALSE(write_mesh(m, temp_path("inf.glb")));

  m = two_part_cube();
  m.uvs.assign(m.positions.size(), glm::vec2(0.0f));
  m.uvs[5].x = std::numeric_limits<float>::quiet_NaN();
  bad = validate_mesh(m);
  ASSERT_FALSE(bad);
  EXPECT_NE(bad.error().message.find("texture coordinate 5"), std::string::npos) << bad.error().message;

  // A GLB whose texture coordinate is NaN is refused by the reader, not handed on.
  m = two_part_cube();
  m.uvs.assign(m.positions.size(), glm::vec2(0.0f));
  m.uvs[4].x = 1234.5f;  // a value found once in the file, then overwritten
  auto glb = encode_glb(m);
  ASSERT_TRUE(glb);
  const float marker = 1234.5f, nan = std::numeric_limits<float>::quiet_NaN();
  const size_t at = glb->find(std::string(reinterpret_cast<const char*>(&marker), 4));
  ASSERT_NE(at, std::string::npos);
  std::memcpy(glb->data() + at, &nan, 4);
  auto nan_uv = parse_glb(*glb);
  ASSERT_FALSE(nan_uv);
  EXPECT_NE(nan_uv.error().message.find("TEXCOORD_0 is not finite"), std::string::npos) << nan_uv.error().message;

  // A unit that overflows the floats on reading is an error naming the file, not an infinite mesh.
  const std::string path = temp_path("cube_for_scale.ply");
  m = two_part_cube();
  m.positions[6].z = 1e10f;
  ASSERT_TRUE(write_mesh(m, path));
  ASSERT_TRUE(read_ply(path, 1e28f));
  auto scaled = read_ply(path, 1e30f);
  ASSERT_FALSE(scaled);
  EXPECT_NE(scaled.error().message.find(path), std::string::npos) << scaled.error().message;
}

// Random byte damage must give an error or a valid mesh, never a crash or an out-of-range index.
TEST(MeshIo, CorruptedFilesNeverYieldInvalidMeshes) {
  const Mesh m = two_part_cube();
  const std::string files[3] = {*encode_obj(m), *encode_ply(m), *encode_glb(m)};
  std::mt19937_64 rng(20261121);
  for (int round = 0; round < 600; ++round) {
    const int kind = round % 3;
    std::string b = files[kind];
    const int flips = 1 + static_cast<int>(rng() % 4);
    for (int k = 0; k < flips; ++k) b[rng() % b.size()] = static_cast<char>(rng());
    auto r = kind == 0 ? parse_obj(b) : kind == 1 ? parse_ply(b) : parse_glb(b);
    if (r) {
      EXPECT_TRUE(validate_mesh(*r)) << "round " << round;
    }
  }
}

TEST(MeshIo, ReadsTheMakeHumanBaseMesh) {
  auto m = read_obj(test::shared_data("mesh/makehuman_base_body.obj"), 0.1f);
  ASSERT_TRUE(m) << m.error().what();
  EXPECT_EQ(m->positions.size(), 13380u);
  EXPECT_EQ(m->triangle_count(), 2u * 13378u);
  glm::vec3 lo(1e9f), hi(-1e9f);
  for (const auto& p : m->positions) {
    lo = glm::min(lo, p);
    hi = glm::max(hi, p);
  }
  EXPECT_NEAR(hi.y - lo.y, 1.6659f, 1e-4f);
  EXPECT_NEAR(hi.x, 0.49627f, 1e-5f);
  EXPECT_NEAR(lo.z, -0.10154f, 1e-5f);
  // And it survives a trip through every writer.
  for (const char* name : {"mh.obj", "mh.ply", "mh.glb"}) {
    const std::string path = temp_path(name);
    ASSERT_TRUE(write_mesh(*m, path));
    auto back = read_mesh(path);
    ASSERT_TRUE(back) << name;
    expect_same_mesh(*m, *back, false);
  }
}

TEST(MeshIo, MissingFileIsAnIoError) {
  auto r = read_obj(temp_path("does_not_exist.obj"));
  ASSERT_FALSE(r);
  EXPECT_NE(r.error().code, Errc::parse_error);
  EXPECT_FALSE(read_mesh("x.stl"));
}

}  // namespace
}  // namespace mimic::avatar::mesh_io_test
