// glTF 2.0 binary (.glb) writing and reading.
#include <cmath>
#include <cstring>
#include <limits>
#include <map>
#include <string>

#include <nlohmann/json.hpp>

#include "mesh_io_internal.h"
#include "mimic/avatar/mesh_io.h"

namespace mimic::avatar {

namespace {

using nlohmann::json;

constexpr uint32_t kMagic = 0x46546C67;  // "glTF"
constexpr uint32_t kChunkJson = 0x4E4F534A;
constexpr uint32_t kChunkBin = 0x004E4942;
constexpr int kFloat = 5126, kUByte = 5121, kUShort = 5123, kUInt = 5125;
constexpr int kArrayBuffer = 34962, kElementArrayBuffer = 34963, kTriangles = 4;

// GLB is little-endian: bytes by shifts, so the files are the same on every host.
void put_u32(std::string& out, uint32_t v) {
  for (int i = 0; i < 4; ++i) out.push_back(static_cast<char>((v >> (8 * i)) & 0xFF));
}

uint32_t get_u32(std::string_view s, size_t at) {
  uint32_t v = 0;
  for (int i = 3; i >= 0; --i) v = (v << 8) | static_cast<uint8_t>(s[at + static_cast<size_t>(i)]);
  return v;
}

}  // namespace

Result<std::string> encode_glb(const Mesh& mesh) {
  if (auto ok = validate_mesh(mesh); !ok) return tl::unexpected(ok.error());
  if (mesh.positions.empty()) return fail(Errc::invalid_argument, "glTF cannot hold a mesh without vertices");
  const bool normals = !mesh.normals.empty();
  const size_t nv = mesh.positions.size();

  std::string bin;
  bin.reserve(nv * (normals ? 24 : 12) + mesh.indices.size() * 4);
  glm::vec3 lo(std::numeric_limits<float>::max()), hi(-std::numeric_limits<float>::max());
  for (const auto& p : mesh.positions) {
    lo = glm::min(lo, p);
    hi = glm::max(hi, p);
  }
  bin.append(reinterpret_cast<const char*>(mesh.positions.data()), nv * sizeof(glm::vec3));
  if (normals)
    for (const auto& n : mesh.normals) {
      const glm::vec3 u = detail::unit_or_up(n);
      bin.append(reinterpret_cast<const char*>(&u), sizeof u);
    }
  const bool uvs = !mesh.uvs.empty();
  const size_t uv_offset = bin.size();
  // glTF puts the texture origin at the image's top-left: t = 1 − v.
  for (const auto& t : mesh.uvs) {
    const glm::vec2 st(t.x, 1.0f - t.y);
    bin.append(reinterpret_cast<const char*>(&st), sizeof st);
  }
  const size_t index_offset = bin.size();
  bin.append(reinterpret_cast<const char*>(mesh.indices.data()), mesh.indices.size() * 4);

  json views = json::array();
  views.push_back({{"buffer", 0}, {"byteOffset", 0}, {"byteLength", nv * 12}, {"target", kArrayBuffer}});
  if (normals)
    views.push_back({{"buffer", 0}, {"byteOffset", nv * 12}, {"byteLength", nv * 12}, {"target", kArrayBuffer}});
  json accessors = json::array();
  accessors.push_back({{"bufferView", 0},
                       {"componentType", kFloat},
                       {"count", nv},
                       {"type", "VEC3"},
                       {"min", {lo.x, lo.y, lo.z}},
                       {"max", {hi.x, hi.y, hi.z}}});
  if (normals) accessors.push_back({{"bufferView", 1}, {"componentType", kFloat}, {"count", nv}, {"type", "VEC3"}});
  int uv_accessor = -1;
  if (uvs) {
    uv_accessor = static_cast<int>(accessors.size());
    accessors.push_back({{"bufferView", views.size()}, {"componentType", kFloat}, {"count", nv}, {"type", "VEC2"}});
    views.push_back({{"buffer", 0}, {"byteOffset", uv_offset}, {"byteLength", nv * 8}, {"target", kArrayBuffer}});
  }
  // With texture coordinates, one material per part: a checker in the part's own colour, so
  // each part's (u, v) square shows on the body.
  json materials = json::array(), textures = json::array(), images = json::array();
  json primitives = json::array();
  const auto parts = covering_parts(mesh);
  const bool has_triangles = !mesh.indices.empty();
  if (has_triangles) {
    const int index_view = static_cast<int>(views.size());
    views.push_back({{"buffer", 0},
                     {"byteOffset", index_offset},
                     {"byteLength", mesh.indices.size() * 4},
                     {"target", kElementArrayBuffer}});
    for (const auto& part : parts) {
      if (part.triangle_count == 0) continue;
      json attributes = {{"POSITION", 0}};
      if (normals) attributes["NORMAL"] = 1;
      json prim = {{"attributes", attributes},
                   {"indices", accessors.size()},
                   {"mode", kTriangles},
                   {"extras", {{"name", part.name}}}};
      if (uvs) {
        prim["attributes"]["TEXCOORD_0"] = uv_accessor;
        const size_t k = materials.size();
        const glm::vec3 rgb = detail::part_colour(k);
        const glm::u8vec3 strong(glm::vec3(60) + rgb * 180.0f), light(glm::vec3(215) + rgb * 40.0f);
        const std::string png = detail::checker_png(64, 8, strong, light);
        while (bin.size() % 4) bin += '\0';
        views.push_back({{"buffer", 0}, {"byteOffset", bin.size()}, {"byteLength", png.size()}});
        bin += png;
        images.push_back({{"bufferView", views.size() - 1}, {"mimeType", "image/png"}, {"name", part.name}});
        textures.push_back({{"source", k}, {"sampler", 0}});
        materials.push_back(
            {{"name", part.name},
             {"pbrMetallicRoughness",
              {{"baseColorTexture", {{"index", k}}}, {"metallicFactor", 0.0}, {"roughnessFactor", 0.8}}}});
        prim["material"] = k;
      }
      primitives.push_back(prim);
      accessors.push_back({{"bufferView", index_view},
                           {"byteOffset", size_t{part.first_triangle} * 12},
                           {"componentType", kUInt},
                           {"count", size_t{part.triangle_count} * 3},
                           {"type", "SCALAR"}});
    }
  } else {
    // A point set still needs a primitive to carry its vertices.
    json attributes = {{"POSITION", 0}};
    if (normals) attributes["NORMAL"] = 1;
    primitives.push_back({{"attributes", attributes}, {"mode", 0}});
  }
  json doc = {{"asset", {{"version", "2.0"}, {"generator", "Mimic"}}},
              {"scene", 0},
              {"scenes", {{{"name", "mimic"}, {"nodes", {0}}}}},
              {"nodes", {{{"name", "mimic_body"}, {"mesh", 0}}}},
              {"meshes", {{{"name", "mimic_body"}, {"primitives", primitives}}}},
              {"accessors", accessors},
              {"bufferViews", views},
              {"buffers", {{{"byteLength", bin.size()}}}}};
  if (!materials.empty()) {
    doc["materials"] = materials;
    doc["textures"] = textures;
    doc["images"] = images;
    doc["samplers"] = {{{"magFilter", 9728}, {"minFilter", 9728}, {"wrapS", 10497}, {"wrapT", 10497}}};
  }
  // Part names are bytes from files; JSON must be UTF-8, so invalid sequences become U+FFFD.
  return detail::glb_container(doc.dump(-1, ' ', false, json::error_handler_t::replace), bin);
}

namespace detail {

glm::vec3 part_colour(size_t k) {
  const float hue = std::fmod(0.618034f * static_cast<float>(k), 1.0f);
  return glm::clamp(glm::abs(glm::mod(hue * 6.0f + glm::vec3(0, 4, 2), 6.0f) - 3.0f) - 1.0f, 0.0f, 1.0f);
}

Result<std::string> glb_container(std::string text, std::string_view bin) {
  while (text.size() % 4) text += ' ';
  const size_t bin_padding = (4 - bin.size() % 4) % 4;
  const size_t total = 12 + 8 + text.size() + 8 + bin.size() + bin_padding;
  if (total > UINT32_MAX) return fail(Errc::invalid_argument, "mesh too large for GLB");
  std::string out;
  out.reserve(total);
  put_u32(out, kMagic);
  put_u32(out, 2);
  put_u32(out, static_cast<uint32_t>(total));
  put_u32(out, static_cast<uint32_t>(text.size()));
  put_u32(out, kChunkJson);
  out += text;
  put_u32(out, static_cast<uint32_t>(bin.size() + bin_padding));
  put_u32(out, kChunkBin);
  out += bin;
  out.append(bin_padding, '\0');
  return out;
}

}  // namespace detail

namespace {

struct Glb {
  json doc;
  std::string_view bin;
};

class GlbReader {
 public:
  GlbReader(const Glb& g, std::string source) : g_(g), src_(std::move(source)) {}

  tl::unexpected<Error> error(const std::string& what) const { return fail(Errc::parse_error, src_ + ": " + what); }

  // Bytes of accessor `a`: element count, component type, components per element, and the
  // address of element i's first component (honouring byteStride).
  struct View {
    size_t count = 0, stride = 0, elem_size = 0;
    int component = 0, components = 0;
    const char* base = nullptr;
  };

  Result<View> accessor(size_t a) const {
    const json& accs = g_.doc.at("accessors");
    if (a >= accs.size()) return error("accessor " + std::to_string(a) + " does not exist");
    const json& acc = accs.at(a);
    View v;
    v.count = acc.at("count").get<size_t>();
    v.component = acc.at("componentType").get<int>();
    const std::string type = acc.at("type").get<std::string>();
    v.components = type == "SCALAR" ? 1 : type == "VEC2" ? 2 : type == "VEC3" ? 3 : type == "VEC4" ? 4 : 0;
    if (v.components == 0) return error("accessor " + std::to_string(a) + " has unsupported type " + type);
    const size_t csize = v.component == kFloat || v.component == kUInt   ? 4
                         : v.component == kUShort || v.component == 5122 ? 2
                         : v.component == kUByte || v.component == 5120  ? 1
                                                                         : 0;
    if (csize == 0) return error("accessor " + std::to_string(a) + " has unknown componentType");
    v.elem_size = csize * static_cast<size_t>(v.components);
    if (!acc.contains("bufferView"))
      return error("accessor " + std::to_string(a) + " has no bufferView (sparse/zero accessors unsupported)");
    const json& views = g_.doc.at("bufferViews");
    const size_t vi = acc.at("bufferView").get<size_t>();
    if (vi >= views.size()) return error("bufferView " + std::to_string(vi) + " does not exist");
    const json& view = views.at(vi);
    if (view.value("buffer", size_t{0}) != 0) return error("only the GLB's own buffer 0 is supported");
    const size_t view_off = view.value("byteOffset", size_t{0});
    const size_t view_len = view.at("byteLength").get<size_t>();
    const size_t acc_off = acc.value("byteOffset", size_t{0});
    v.stride = view.value("byteStride", size_t{0});
    if (v.stride == 0) v.stride = v.elem_size;
    if (v.stride < v.elem_size) return error("bufferView " + std::to_string(vi) + " stride is smaller than an element");
    if (view_off > g_.bin.size() || view_len > g_.bin.size() - view_off)
      return error("bufferView " + std::to_string(vi) + " runs past the BIN chunk");
    if (v.count > 0) {
      if (acc_off > view_len || v.count - 1 > (view_len - acc_off) / v.stride ||
          (v.count - 1) * v.stride + v.elem_size > view_len - acc_off)
        return error("accessor " + std::to_string(a) + " runs past its bufferView");
    }
    v.base = g_.bin.data() + view_off + acc_off;
    return v;
  }

  double component(const View& v, size_t i, int k) const {
    const char* p = v.base + i * v.stride;
    switch (v.component) {
      case kFloat: {
        float f;
        std::memcpy(&f, p + 4 * k, 4);
        return f;
      }
      case kUInt: {
        uint32_t u;
        std::memcpy(&u, p + 4 * k, 4);
        return u;
      }
      case kUShort: {
        uint16_t u;
        std::memcpy(&u, p + 2 * k, 2);
        return u;
      }
      case 5122: {
        int16_t u;
        std::memcpy(&u, p + 2 * k, 2);
        return u;
      }
      case kUByte: return static_cast<unsigned char>(p[k]);
      case 5120: return static_cast<signed char>(p[k]);
      default: return 0;
    }
  }

 private:
  const Glb& g_;
  std::string src_;
};

Result<Mesh> decode_glb(const Glb& g, const std::string& src) {
  GlbReader r(g, src);
  const json& doc = g.doc;
  if (!doc.is_object()) return r.error("JSON chunk is not an object");
  const std::string version = doc.at("asset").at("version").get<std::string>();
  if (version.rfind("2.", 0) != 0) return r.error("glTF version " + version + " is not 2.x");
  if (!doc.contains("meshes") || doc.at("meshes").empty()) return r.error("file has no mesh");
  const json& prims = doc.at("meshes").at(0).at("primitives");
  Mesh mesh;
  // (POSITION, NORMAL) accessors -> (first vertex, vertex count) in the merged vertex list.
  std::map<std::pair<size_t, long long>, std::pair<uint32_t, size_t>> base_of;
  std::vector<uint32_t> tri_group;
  std::vector<std::string> names;
  bool want_normals = true, want_uvs = true;
  std::vector<glm::vec3> normals;
  std::vector<glm::vec2> uvs;
  for (size_t pi = 0; pi < prims.size(); ++pi) {
    const json& prim = prims.at(pi);
    const int mode = prim.value("mode", kTriangles);
    const json& attrs = prim.at("attributes");
    const size_t pos_acc = attrs.at("POSITION").get<size_t>();
    const long long nrm_acc = attrs.contains("NORMAL") ? attrs.at("NORMAL").get<long long>() : -1;
    if (nrm_acc < 0) want_normals = false;
    auto key = std::make_pair(pos_acc, nrm_acc);
    uint32_t base;
    size_t vcount;
    if (auto it = base_of.find(key); it != base_of.end()) {
      base = it->second.first;
      vcount = it->second.second;
    } else {
      auto pv = r.accessor(pos_acc);
      if (!pv) return tl::unexpected(pv.error());
      if (pv->component != kFloat || pv->components != 3) return r.error("POSITION must be float VEC3");
      if (mesh.positions.size() + pv->count > UINT32_MAX) return r.error("too many vertices");
      base = static_cast<uint32_t>(mesh.positions.size());
      for (size_t i = 0; i < pv->count; ++i) {
        const glm::vec3 p(r.component(*pv, i, 0), r.component(*pv, i, 1), r.component(*pv, i, 2));
        if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z)) return r.error("POSITION is not finite");
        mesh.positions.push_back(p);
      }
      if (attrs.contains("TEXCOORD_0")) {
        auto tv = r.accessor(attrs.at("TEXCOORD_0").get<size_t>());
        if (!tv) return tl::unexpected(tv.error());
        if (tv->component != kFloat || tv->components != 2 || tv->count != pv->count)
          return r.error("TEXCOORD_0 must be float VEC2 with one per POSITION");
        for (size_t i = 0; i < tv->count; ++i) {
          const glm::vec2 uv(r.component(*tv, i, 0), 1.0 - r.component(*tv, i, 1));
          if (!std::isfinite(uv.x) || !std::isfinite(uv.y)) return r.error("TEXCOORD_0 is not finite");
          uvs.push_back(uv);
        }
      } else {
        want_uvs = false;
        uvs.resize(mesh.positions.size(), glm::vec2(0.0f));
      }
      if (nrm_acc >= 0) {
        auto nv = r.accessor(static_cast<size_t>(nrm_acc));
        if (!nv) return tl::unexpected(nv.error());
        if (nv->component != kFloat || nv->components != 3 || nv->count != pv->count)
          return r.error("NORMAL must be float VEC3 with one per POSITION");
        for (size_t i = 0; i < nv->count; ++i)
          normals.push_back(
              detail::unit_or_up({r.component(*nv, i, 0), r.component(*nv, i, 1), r.component(*nv, i, 2)}));
      } else {
        normals.resize(mesh.positions.size(), glm::vec3(0, 1, 0));
      }
      vcount = mesh.positions.size() - base;
      base_of.emplace(key, std::make_pair(base, vcount));
    }
    if (mode == 0) continue;  // points carry vertices only
    if (mode != kTriangles) return r.error("primitive " + std::to_string(pi) + " is not a triangle list");
    std::string name = "part" + std::to_string(pi);
    if (prim.contains("extras") && prim.at("extras").is_object() && prim.at("extras").contains("name") &&
        prim.at("extras").at("name").is_string())
      name = clean_name(prim.at("extras").at("name").get<std::string>());
    names.push_back(name);
    const auto group = static_cast<uint32_t>(names.size() - 1);
    std::vector<uint32_t> local;
    if (prim.contains("indices")) {
      auto iv = r.accessor(prim.at("indices").get<size_t>());
      if (!iv) return tl::unexpected(iv.error());
      if (iv->components != 1 || !(iv->component == kUInt || iv->component == kUShort || iv->component == kUByte))
        return r.error("primitive " + std::to_string(pi) + " indices must be unsigned scalars");
      for (size_t i = 0; i < iv->count; ++i) local.push_back(static_cast<uint32_t>(r.component(*iv, i, 0)));
    } else {
      for (size_t i = 0; i < vcount; ++i) local.push_back(static_cast<uint32_t>(i));
    }
    if (local.size() % 3) return r.error("primitive " + std::to_string(pi) + " index count is not a multiple of 3");
    for (uint32_t i : local) {
      if (i >= vcount)
        return r.error("primitive " + std::to_string(pi) + " index " + std::to_string(i) + " is out of range");
      mesh.indices.push_back(base + i);
    }
    tri_group.insert(tri_group.end(), local.size() / 3, group);
  }
  if (want_normals && !mesh.positions.empty()) mesh.normals = std::move(normals);
  if (want_uvs && !mesh.positions.empty() && uvs.size() == mesh.positions.size()) mesh.uvs = std::move(uvs);
  detail::gather_parts(mesh, tri_group, names);
  return mesh;
}

}  // namespace

Result<Mesh> parse_glb(std::string_view bytes, std::string_view source) {
  const std::string src(source);
  auto error = [&](const std::string& what) { return fail(Errc::parse_error, src + ": " + what); };
  if (bytes.size() < 12) return error("too short for a GLB header");
  if (get_u32(bytes, 0) != kMagic) return error("not a GLB file (bad magic)");
  if (get_u32(bytes, 4) != 2) return error("GLB container version " + std::to_string(get_u32(bytes, 4)) + " is not 2");
  const uint32_t total = get_u32(bytes, 8);
  if (total > bytes.size()) return error("header length " + std::to_string(total) + " exceeds the file size");
  Glb g;
  bool have_json = false;
  size_t at = 12;
  int chunk = 0;
  while (at + 8 <= total) {
    const uint32_t len = get_u32(bytes, at), type = get_u32(bytes, at + 4);
    if (len > total - at - 8)
      return error("chunk " + std::to_string(chunk) + " at byte " + std::to_string(at) + " runs past the end");
    const std::string_view data = bytes.substr(at + 8, len);
    if (chunk == 0) {
      if (type != kChunkJson) return error("first chunk is not JSON");
      g.doc = json::parse(data.begin(), data.end(), nullptr, false);
      if (g.doc.is_discarded()) return error("JSON chunk is not valid JSON");
      have_json = true;
    } else if (chunk == 1 && type == kChunkBin) {
      g.bin = data;
    }
    at += 8 + len;
    ++chunk;
  }
  if (!have_json) return error("no JSON chunk");
  try {
    return decode_glb(g, src);
  } catch (const json::exception& e) {
    return error(std::string("unexpected glTF structure: ") + e.what());
  }
}

}  // namespace mimic::avatar
