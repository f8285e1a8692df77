// Stanford PLY: binary little-endian writing; ascii and binary reading.
#include <algorithm>
#include <bit>
#include <charconv>
#include <cmath>
#include <cstring>
#include <limits>
#include <map>
#include <string>

#include "mesh_io_internal.h"
#include "mimic/avatar/mesh_io.h"

namespace mimic::avatar {

static_assert(std::endian::native == std::endian::little, "PLY/GLB byte code assumes a little-endian host");

namespace {

template <class T>
void put(std::string& out, T v) {
  char b[sizeof(T)];
  std::memcpy(b, &v, sizeof(T));
  out.append(b, sizeof(T));
}

enum class Type { i8, u8, i16, u16, i32, u32, f32, f64, invalid };

Type type_of(std::string_view s) {
  if (s == "char" || s == "int8") return Type::i8;
  if (s == "uchar" || s == "uint8") return Type::u8;
  if (s == "short" || s == "int16") return Type::i16;
  if (s == "ushort" || s == "uint16") return Type::u16;
  if (s == "int" || s == "int32") return Type::i32;
  if (s == "uint" || s == "uint32") return Type::u32;
  if (s == "float" || s == "float32") return Type::f32;
  if (s == "double" || s == "float64") return Type::f64;
  return Type::invalid;
}

size_t size_of(Type t) {
  switch (t) {
    case Type::i8:
    case Type::u8: return 1;
    case Type::i16:
    case Type::u16: return 2;
    case Type::i32:
    case Type::u32:
    case Type::f32: return 4;
    case Type::f64: return 8;
    default: return 0;
  }
}

struct Property {
  std::string name;
  Type type = Type::invalid;
  bool is_list = false;
  Type count_type = Type::invalid;
};

struct Element {
  std::string name;
  uint64_t count = 0;
  std::vector<Property> props;
};

enum class Format { ascii, binary_le, binary_be };

// Reads scalars from the body in either encoding, with bounds checks.
class Reader {
 public:
  Reader(std::string_view body, size_t body_offset, Format f, std::string_view source)
      : body_(body), base_(body_offset), format_(f), source_(source) {}

  Result<double> read(Type t) {
    if (format_ == Format::ascii) return read_text();
    const size_t n = size_of(t);
    if (pos_ + n > body_.size())
      return fail(Errc::parse_error,
                  std::string(source_) + ": data ends early at byte " + std::to_string(base_ + pos_));
    unsigned char b[8];
    std::memcpy(b, body_.data() + pos_, n);
    if (format_ == Format::binary_be)
      for (size_t i = 0; i < n / 2; ++i) std::swap(b[i], b[n - 1 - i]);
    pos_ += n;
    switch (t) {
      case Type::i8: {
        int8_t v;
        std::memcpy(&v, b, 1);
        return v;
      }
      case Type::u8: return b[0];
      case Type::i16: {
        int16_t v;
        std::memcpy(&v, b, 2);
        return v;
      }
      case Type::u16: {
        uint16_t v;
        std::memcpy(&v, b, 2);
        return v;
      }
      case Type::i32: {
        int32_t v;
        std::memcpy(&v, b, 4);
        return v;
      }
      case Type::u32: {
        uint32_t v;
        std::memcpy(&v, b, 4);
        return v;
      }
      case Type::f32: {
        float v;
        std::memcpy(&v, b, 4);
        return v;
      }
      case Type::f64: {
        double v;
        std::memcpy(&v, b, 8);
        return v;
      }
      default: return 0.0;
    }
  }

  size_t remaining() const { return body_.size() - pos_; }
  std::string where() const {
    return format_ == Format::ascii ? "data line " + std::to_string(line_) : "byte " + std::to_string(base_ + pos_);
  }

 private:
  Result<double> read_text() {
    while (pos_ < body_.size() && std::isspace(static_cast<unsigned char>(body_[pos_]))) {
      if (body_[pos_] == '\n') ++line_;
      ++pos_;
    }
    size_t end = pos_;
    while (end < body_.size() && !std::isspace(static_cast<unsigned char>(body_[end]))) ++end;
    if (end == pos_) return fail(Errc::parse_error, std::string(source_) + ": data ends early");
    double v = 0;
    std::string_view tok = body_.substr(pos_, end - pos_);
    if (!tok.empty() && tok.front() == '+') tok.remove_prefix(1);
    auto [p, ec] = std::from_chars(tok.data(), tok.data() + tok.size(), v);
    if (ec != std::errc() || p != tok.data() + tok.size())
      return fail(Errc::parse_error, std::string(source_) + ": data line " + std::to_string(line_) + ": bad number '" +
                                         std::string(body_.substr(pos_, end - pos_)) + "'");
    pos_ = end;
    return v;
  }

  std::string_view body_;
  size_t base_;
  Format format_;
  std::string_view source_;
  size_t pos_ = 0;
  size_t line_ = 1;
};

}  // namespace

Result<std::string> encode_ply(const Mesh& mesh) {
  if (auto ok = validate_mesh(mesh); !ok) return tl::unexpected(ok.error());
  const auto parts = covering_parts(mesh);
  if (parts.size() > 65536) return fail(Errc::invalid_argument, "PLY part ids are 16-bit: too many parts");
  const bool normals = !mesh.normals.empty();
  std::string out = "ply\nformat binary_little_endian 1.0\ncomment Mimic avatar mesh: metres, +Y up, faces +Z\n";
  for (size_t i = 0; i < parts.size(); ++i) out += "comment part " + std::to_string(i) + " " + parts[i].name + "\n";
  out += "element vertex " + std::to_string(mesh.positions.size()) + "\n";
  out += "property float x\nproperty float y\nproperty float z\n";
  if (normals) out += "property float nx\nproperty float ny\nproperty float nz\n";
  const bool uvs = !mesh.uvs.empty();
  if (uvs) out += "property float s\nproperty float t\n";
  out += "element face " + std::to_string(mesh.triangle_count()) + "\n";
  out += "property list uchar int vertex_indices\nproperty ushort part\nend_header\n";
  out.reserve(out.size() + mesh.positions.size() * (normals ? 24 : 12) + mesh.triangle_count() * 15);
  for (size_t i = 0; i < mesh.positions.size(); ++i) {
    for (int k = 0; k < 3; ++k) put(out, mesh.positions[i][k]);
    if (normals) {
      const glm::vec3 n = detail::unit_or_up(mesh.normals[i]);
      for (int k = 0; k < 3; ++k) put(out, n[k]);
    }
    if (uvs) put(out, mesh.uvs[i].x), put(out, mesh.uvs[i].y);
  }
  for (size_t p = 0; p < parts.size(); ++p)
    for (uint32_t t = parts[p].first_triangle; t < parts[p].first_triangle + parts[p].triangle_count; ++t) {
      put(out, uint8_t{3});
      for (int k = 0; k < 3; ++k) put(out, static_cast<int32_t>(mesh.indices[3 * t + k]));
      put(out, static_cast<uint16_t>(p));
    }
  return out;
}

namespace {

struct PlyHeader {
  Format format = Format::ascii;
  std::vector<Element> elements;
  std::map<long long, std::string> part_names;
  size_t body_at = 0;  // byte offset of the data after end_header
};

// Header: text lines up to end_header.
Result<PlyHeader> parse_ply_header(std::string_view bytes, const std::string& src) {
  auto error = [&](const std::string& what) { return fail(Errc::parse_error, src + ": " + what); };
  size_t pos = 0, line_no = 0;
  bool have_format = false, ended = false;
  PlyHeader h;
  Format& format = h.format;
  std::vector<Element>& elements = h.elements;
  std::map<long long, std::string>& part_names = h.part_names;
  while (pos < bytes.size() && !ended) {
    size_t eol = bytes.find('\n', pos);
    if (eol == std::string_view::npos) return error("header has no end_header line");
    std::string_view line = bytes.substr(pos, eol - pos);
    pos = eol + 1;
    ++line_no;
    if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
    std::vector<std::string_view> tok;
    for (size_t i = 0; i < line.size();) {
      while (i < line.size() && (line[i] == ' ' || line[i] == '\t')) ++i;
      size_t j = i;
      while (j < line.size() && line[j] != ' ' && line[j] != '\t') ++j;
      if (j > i) tok.push_back(line.substr(i, j - i));
      i = j;
    }
    auto at = [&](const std::string& what) { return error("line " + std::to_string(line_no) + ": " + what); };
    if (line_no == 1) {
      if (line != "ply") return error("not a PLY file (first line is not 'ply')");
      continue;
    }
    if (tok.empty()) continue;
    if (tok[0] == "format") {
      if (tok.size() < 2) return at("format needs a value");
      if (tok[1] == "ascii")
        format = Format::ascii;
      else if (tok[1] == "binary_little_endian")
        format = Format::binary_le;
      else if (tok[1] == "binary_big_endian")
        format = Format::binary_be;
      else
        return at("unknown format '" + std::string(tok[1]) + "'");
      have_format = true;
    } else if (tok[0] == "comment") {
      if (tok.size() >= 4 && tok[1] == "part") {
        long long id = 0;
        auto [p, ec] = std::from_chars(tok[2].data(), tok[2].data() + tok[2].size(), id);
        if (ec == std::errc() && p == tok[2].data() + tok[2].size()) {
          const size_t name_at = static_cast<size_t>(tok[3].data() - line.data());
          part_names[id] = clean_name(line.substr(name_at));
        }
      }
    } else if (tok[0] == "obj_info") {
    } else if (tok[0] == "element") {
      if (tok.size() != 3) return at("element needs a name and a count");
      uint64_t count = 0;
      auto [p, ec] = std::from_chars(tok[2].data(), tok[2].data() + tok[2].size(), count);
      if (ec != std::errc() || p != tok[2].data() + tok[2].size())
        return at("bad element count '" + std::string(tok[2]) + "'");
      // One vertex list: a second one could carry other attributes than the first.
      if (tok[1] == "vertex" &&
          std::any_of(elements.begin(), elements.end(), [](const Element& e) { return e.name == "vertex"; }))
        return at("a second vertex element");
      elements.push_back({std::string(tok[1]), count, {}});
    } else if (tok[0] == "property") {
      if (elements.empty()) return at("property before any element");
      Property prop;
      if (tok.size() == 5 && tok[1] == "list") {
        prop.is_list = true;
        prop.count_type = type_of(tok[2]);
        prop.type = type_of(tok[3]);
        prop.name = tok[4];
        if (prop.count_type == Type::invalid || prop.type == Type::invalid || prop.count_type == Type::f32 ||
            prop.count_type == Type::f64)
          return at("bad list property types");
      } else if (tok.size() == 3) {
        prop.type = type_of(tok[1]);
        prop.name = tok[2];
        if (prop.type == Type::invalid) return at("unknown property type '" + std::string(tok[1]) + "'");
      } else {
        return at("malformed property line");
      }
      elements.back().props.push_back(prop);
    } else if (tok[0] == "end_header") {
      ended = true;
    } else {
      return at("unknown header keyword '" + std::string(tok[0]) + "'");
    }
  }
  if (!ended) return error("header has no end_header line");
  if (!have_format) return error("header has no format line");
  h.body_at = pos;
  return h;
}

// What the elements read so far hold: the mesh's vertices, faces as triangles (index values not
// yet checked against the vertex count) and their part groups.
struct PlyBody {
  Mesh mesh;
  std::vector<uint32_t> tri_group;
  std::vector<std::string> names;
  std::map<long long, uint32_t> group_of_id;
  std::vector<double> face_index_values;
  bool saw_vertex = false;
};

Status read_element(const Element& el, const PlyHeader& h, Reader& in, const std::string& src, PlyBody& out) {
  auto error = [&](const std::string& what) { return fail(Errc::parse_error, src + ": " + what); };
  Mesh& mesh = out.mesh;
  auto& tri_group = out.tri_group;
  auto& names = out.names;
  auto& group_of_id = out.group_of_id;
  auto& face_index_values = out.face_index_values;
  const auto& part_names = h.part_names;
  const bool is_vertex = el.name == "vertex", is_face = el.name == "face";
  int ix = -1, iy = -1, iz = -1, inx = -1, iny = -1, inz = -1, iidx = -1, ipart = -1, is = -1, itc = -1;
  for (int i = 0; i < static_cast<int>(el.props.size()); ++i) {
    const auto& n = el.props[i].name;
    const bool list = el.props[i].is_list;
    if (is_vertex && !list) {
      if (n == "x")
        ix = i;
      else if (n == "y")
        iy = i;
      else if (n == "z")
        iz = i;
      else if (n == "nx")
        inx = i;
      else if (n == "ny")
        iny = i;
      else if (n == "nz")
        inz = i;
      else if (n == "s" || n == "u" || n == "texture_u")
        is = i;
      else if (n == "t" || n == "v" || n == "texture_v")
        itc = i;
    }
    if (is_face && list && (n == "vertex_indices" || n == "vertex_index")) iidx = i;
    if (is_face && !list && n == "part") ipart = i;
  }
  if (is_vertex) {
    if (ix < 0 || iy < 0 || iz < 0) return error("vertex element lacks x, y or z");
    out.saw_vertex = true;
  }
  if (is_face && iidx < 0) return error("face element lacks a vertex_indices list");
  const bool has_normals = inx >= 0 && iny >= 0 && inz >= 0;
  const bool has_uvs = is >= 0 && itc >= 0;
  // Never trust a header count for allocation beyond what the bytes could hold.
  if (is_vertex) mesh.positions.reserve(std::min<uint64_t>(el.count, in.remaining() / 3 + 1));
  std::vector<double> vals(el.props.size());
  std::vector<double> poly;
  for (uint64_t e = 0; e < el.count; ++e) {
    poly.clear();
    for (size_t i = 0; i < el.props.size(); ++i) {
      const Property& pr = el.props[i];
      if (!pr.is_list) {
        auto v = in.read(pr.type);
        if (!v) return tl::unexpected(v.error());
        vals[i] = *v;
        continue;
      }
      auto cnt = in.read(pr.count_type);
      if (!cnt) return tl::unexpected(cnt.error());
      if (!(*cnt >= 0) || *cnt > 1e6) return error(el.name + " " + std::to_string(e) + ": bad list length");
      const auto count = static_cast<size_t>(*cnt);
      for (size_t k = 0; k < count; ++k) {
        auto v = in.read(pr.type);
        if (!v) return tl::unexpected(v.error());
        if (static_cast<int>(i) == iidx) poly.push_back(*v);
      }
    }
    if (is_vertex) {
      for (int i : {ix, iy, iz, inx, iny, inz, is, itc})
        if (i >= 0 && !(std::abs(vals[i]) <= std::numeric_limits<float>::max()))
          return error("vertex " + std::to_string(e) + " has a value that is not a finite float");
      mesh.positions.emplace_back(vals[ix], vals[iy], vals[iz]);
      if (has_normals) mesh.normals.push_back(detail::unit_or_up(glm::vec3(vals[inx], vals[iny], vals[inz])));
      if (has_uvs) mesh.uvs.emplace_back(vals[is], vals[itc]);
    } else if (is_face) {
      if (poly.size() < 3) return error("face " + std::to_string(e) + " has fewer than 3 vertices");
      long long id = 0;
      if (ipart >= 0) {
        if (!(std::abs(vals[ipart]) <= 1e15)) return error("face " + std::to_string(e) + ": bad part id");
        id = static_cast<long long>(vals[ipart]);
      }
      auto [it, inserted] = group_of_id.emplace(id, static_cast<uint32_t>(names.size()));
      if (inserted) {
        auto nm = part_names.find(id);
        names.push_back(nm != part_names.end() ? nm->second : (ipart >= 0 ? "part" + std::to_string(id) : "mesh"));
      }
      for (size_t k = 1; k + 1 < poly.size(); ++k) {
        for (double v : {poly[0], poly[k], poly[k + 1]}) face_index_values.push_back(v);
        tri_group.push_back(it->second);
      }
    }
  }
  return {};
}

}  // namespace

Result<Mesh> parse_ply(std::string_view bytes, std::string_view source) {
  const std::string src(source);
  auto error = [&](const std::string& what) { return fail(Errc::parse_error, src + ": " + what); };
  auto h = parse_ply_header(bytes, src);
  if (!h) return tl::unexpected(h.error());
  PlyBody b;
  Reader in(bytes.substr(h->body_at), h->body_at, h->format, source);
  for (const Element& el : h->elements)
    if (auto st = read_element(el, *h, in, src, b); !st) return tl::unexpected(st.error());
  if (!b.saw_vertex) return error("no vertex element");
  Mesh& mesh = b.mesh;
  mesh.indices.reserve(b.face_index_values.size());
  for (size_t i = 0; i < b.face_index_values.size(); ++i) {
    const double v = b.face_index_values[i];
    if (!(v >= 0) || v >= static_cast<double>(mesh.positions.size()) || v != std::floor(v))
      return error("face " + std::to_string(i / 3) + " (after triangulation) has vertex index " + std::to_string(v) +
                   " out of range (" + std::to_string(mesh.positions.size()) + " vertices)");
    mesh.indices.push_back(static_cast<uint32_t>(v));
  }
  detail::gather_parts(mesh, b.tri_group, b.names);
  return std::move(b.mesh);
}

}  // namespace mimic::avatar
