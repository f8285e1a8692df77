// Wavefront OBJ reading and writing.
#include <charconv>
#include <cmath>
#include <cstdio>
#include <string>
#include <unordered_map>

#include "mesh_io_internal.h"
#include "mimic/avatar/mesh_io.h"

namespace mimic::avatar {

namespace {

void append_float(std::string& out, float v) {
  char buf[32];
  // %.9g round-trips every float exactly.
  const int n = std::snprintf(buf, sizeof buf, "%.9g", static_cast<double>(v));
  out.append(buf, static_cast<size_t>(n));
}

void append_vec(std::string& out, const char* tag, glm::vec3 v) {
  out += tag;
  for (int k = 0; k < 3; ++k) {
    out += ' ';
    append_float(out, v[k]);
  }
  out += '\n';
}

bool is_space(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\f' || c == '\v'; }

// Splits a line into whitespace-separated tokens (views into the line).
int split(std::string_view line, std::string_view* tokens, int max_tokens, size_t& extra) {
  int n = 0;
  extra = 0;
  size_t i = 0;
  while (i < line.size()) {
    while (i < line.size() && is_space(line[i])) ++i;
    if (i >= line.size()) break;
    size_t j = i;
    while (j < line.size() && !is_space(line[j])) ++j;
    if (n < max_tokens)
      tokens[n++] = line.substr(i, j - i);
    else
      ++extra;
    i = j;
  }
  return n;
}

bool parse_float(std::string_view s, float& out) {
  if (!s.empty() && s.front() == '+') s.remove_prefix(1);
  const char* end = s.data() + s.size();
  auto [p, ec] = std::from_chars(s.data(), end, out);
  return ec == std::errc() && p == end && std::isfinite(out);
}

bool parse_int(std::string_view s, long long& out) {
  if (!s.empty() && s.front() == '+') s.remove_prefix(1);
  const char* end = s.data() + s.size();
  auto [p, ec] = std::from_chars(s.data(), end, out);
  return ec == std::errc() && p == end;
}

std::string_view trim(std::string_view s) {
  while (!s.empty() && is_space(s.front())) s.remove_prefix(1);
  while (!s.empty() && is_space(s.back())) s.remove_suffix(1);
  return s;
}

struct Corner {
  long long v = 0;   // as written (1-based, or negative = relative)
  long long vn = 0;  // 0 = none
  long long vt = 0;  // 0 = none
};

}  // namespace

Result<std::string> encode_obj(const Mesh& mesh) {
  if (auto ok = validate_mesh(mesh); !ok) return tl::unexpected(ok.error());
  const bool normals = !mesh.normals.empty();
  std::string out;
  out.reserve(mesh.positions.size() * (normals ? 80 : 40) + mesh.indices.size() * 12 + 256);
  out += "# Mimic avatar mesh: metres, +Y up, the body faces +Z, counter-clockwise faces\n";
  out += "o mimic_body\n";
  for (const auto& p : mesh.positions) append_vec(out, "v", p);
  if (normals)
    for (const auto& n : mesh.normals) append_vec(out, "vn", detail::unit_or_up(n));
  const bool uvs = !mesh.uvs.empty();
  for (const auto& t : mesh.uvs) {
    out += "vt ";
    append_float(out, t.x);
    out += ' ';
    append_float(out, t.y);
    out += '\n';
  }
  char buf[96];
  for (const auto& part : covering_parts(mesh)) {
    out += "g " + part.name + "\n";
    for (uint32_t t = part.first_triangle; t < part.first_triangle + part.triangle_count; ++t) {
      const uint32_t a = mesh.indices[3 * t] + 1, b = mesh.indices[3 * t + 1] + 1, c = mesh.indices[3 * t + 2] + 1;
      const int n = normals && uvs
                        ? std::snprintf(buf, sizeof buf, "f %u/%u/%u %u/%u/%u %u/%u/%u\n", a, a, a, b, b, b, c, c, c)
                    : normals ? std::snprintf(buf, sizeof buf, "f %u//%u %u//%u %u//%u\n", a, a, b, b, c, c)
                    : uvs     ? std::snprintf(buf, sizeof buf, "f %u/%u %u/%u %u/%u\n", a, a, b, b, c, c)
                              : std::snprintf(buf, sizeof buf, "f %u %u %u\n", a, b, c);
      out.append(buf, static_cast<size_t>(n));
    }
  }
  return out;
}

namespace {

// The corners of an "f" line (re-split without a token limit: polygons may have many corners),
// relative indices resolved against the counts read so far. Returns why it is bad, or "".
std::string read_face(std::string_view line, size_t v_count, size_t vt_count, size_t vn_count,
                      std::vector<Corner>& corners) {
  corners.clear();
  size_t i = 0;
  std::string_view rest = line.substr(line.find('f') + 1);
  while (i < rest.size()) {
    while (i < rest.size() && is_space(rest[i])) ++i;
    if (i >= rest.size()) break;
    size_t j = i;
    while (j < rest.size() && !is_space(rest[j])) ++j;
    const std::string_view item = rest.substr(i, j - i);
    i = j;
    std::string_view fields[3];
    int nf = 0;
    size_t s = 0;
    while (nf < 3) {
      const size_t slash = item.find('/', s);
      fields[nf++] = item.substr(s, slash == std::string_view::npos ? std::string_view::npos : slash - s);
      if (slash == std::string_view::npos) break;
      s = slash + 1;
      if (nf == 3) return "face corner '" + std::string(item) + "' has too many '/'";
    }
    Corner c;
    if (!parse_int(fields[0], c.v) || c.v == 0) return "bad vertex index '" + std::string(item) + "' in f";
    if (nf >= 2 && !fields[1].empty() && (!parse_int(fields[1], c.vt) || c.vt == 0))
      return "bad texture index '" + std::string(item) + "' in f";
    if (c.vt < 0) {
      c.vt += static_cast<long long>(vt_count) + 1;
      if (c.vt <= 0) return "relative texture index '" + std::string(item) + "' points before the first vt";
    }
    if (nf == 3 && (!parse_int(fields[2], c.vn) || c.vn == 0))
      return "bad normal index '" + std::string(item) + "' in f";
    // Relative indices count back from the vertices read so far.
    if (c.v < 0) {
      c.v += static_cast<long long>(v_count) + 1;
      if (c.v <= 0) return "relative vertex index '" + std::string(item) + "' points before the first vertex";
    }
    if (c.vn < 0) {
      c.vn += static_cast<long long>(vn_count) + 1;
      if (c.vn <= 0) return "relative normal index '" + std::string(item) + "' points before the first normal";
    }
    if (c.v > UINT32_MAX) return "vertex index '" + std::string(item) + "' is too large";
    corners.push_back(c);
  }
  return {};
}

// Per-vertex normals and texture coordinates from the corners' references: the first reference
// wins at a shared vertex; a vertex no face gave a normal gets its area-weighted face normal, one
// without coordinates (0, 0).
void resolve_corner_attributes(Mesh& mesh, const std::vector<glm::vec3>& vn, const std::vector<glm::vec2>& vt,
                               const std::vector<long long>& corner_vn, const std::vector<long long>& corner_vt,
                               bool any_normal_ref, bool any_uv_ref) {
  if (any_normal_ref) {
    std::vector<glm::vec3> normal(mesh.positions.size(), glm::vec3(0));
    std::vector<char> has(mesh.positions.size(), 0);
    for (size_t i = 0; i < mesh.indices.size(); ++i)
      if (corner_vn[i] > 0 && !has[mesh.indices[i]]) {
        normal[mesh.indices[i]] = vn[static_cast<size_t>(corner_vn[i] - 1)];
        has[mesh.indices[i]] = 1;
      }
    // Vertices no face gave a normal get their area-weighted face normal.
    for (size_t t = 0; t < mesh.triangle_count(); ++t) {
      const uint32_t a = mesh.indices[3 * t], b = mesh.indices[3 * t + 1], c = mesh.indices[3 * t + 2];
      const glm::vec3 fn = glm::cross(mesh.positions[b] - mesh.positions[a], mesh.positions[c] - mesh.positions[a]);
      for (uint32_t v : {a, b, c})
        if (!has[v]) normal[v] += fn;
    }
    for (auto& nn : normal) nn = detail::unit_or_up(nn);
    mesh.normals = std::move(normal);
  }
  if (any_uv_ref) {
    // First reference wins at a shared vertex, as for normals; unreferenced vertices get (0, 0).
    mesh.uvs.assign(mesh.positions.size(), glm::vec2(0.0f));
    std::vector<char> has(mesh.positions.size(), 0);
    for (size_t i = 0; i < mesh.indices.size(); ++i)
      if (corner_vt[i] > 0 && !has[mesh.indices[i]]) {
        mesh.uvs[mesh.indices[i]] = vt[static_cast<size_t>(corner_vt[i] - 1)];
        has[mesh.indices[i]] = 1;
      }
  }
}

}  // namespace

Result<Mesh> parse_obj(std::string_view text, std::string_view source) {
  Mesh mesh;
  std::vector<glm::vec3> vn;
  std::vector<glm::vec2> vt;
  std::vector<uint32_t> tri_group;
  std::vector<std::string> names{"mesh"};
  std::unordered_map<std::string, uint32_t> group_of{{"mesh", 0}};
  uint32_t group = 0;
  // Per triangle corner: the 1-based normal index it named (0 = none), resolved at the end.
  std::vector<long long> corner_vn, corner_vt;
  std::vector<size_t> pending_line;  // source line of each corner, for late range errors
  bool any_normal_ref = false, any_uv_ref = false;

  auto error = [&](size_t line, const std::string& what) {
    return fail(Errc::parse_error, std::string(source) + ":" + std::to_string(line) + ": " + what);
  };

  size_t line_no = 0, pos = 0;
  std::vector<Corner> corners;
  while (pos < text.size()) {
    size_t eol = text.find('\n', pos);
    if (eol == std::string_view::npos) eol = text.size();
    std::string_view line = text.substr(pos, eol - pos);
    pos = eol + 1;
    ++line_no;
    if (auto hash = line.find('#'); hash != std::string_view::npos) line = line.substr(0, hash);
    std::string_view tok[8];
    size_t extra = 0;
    const int n = split(line, tok, 8, extra);
    if (n == 0) continue;
    const std::string_view key = tok[0];
    if (key == "v" || key == "vn") {
      glm::vec3 p;
      if (n < 4) return error(line_no, std::string(key) + " needs 3 numbers");
      for (int k = 0; k < 3; ++k)
        if (!parse_float(tok[1 + k], p[k]))
          return error(line_no, "bad number '" + std::string(tok[1 + k]) + "' in " + std::string(key));
      (key == "v" ? mesh.positions : vn).push_back(p);
    } else if (key == "vt") {
      glm::vec2 t(0.0f);
      if (n < 2) return error(line_no, "vt needs at least 1 number");
      for (int k = 0; k < std::min(n - 1, 2); ++k)
        if (!parse_float(tok[1 + k], t[k])) return error(line_no, "bad number '" + std::string(tok[1 + k]) + "' in vt");
      vt.push_back(t);
    } else if (key == "f") {
      if (std::string why = read_face(line, mesh.positions.size(), vt.size(), vn.size(), corners); !why.empty())
        return error(line_no, why);
      if (corners.size() < 3)
        return error(line_no, "face needs at least 3 vertices, has " + std::to_string(corners.size()));
      for (size_t k = 1; k + 1 < corners.size(); ++k) {
        for (const Corner& c : {corners[0], corners[k], corners[k + 1]}) {
          mesh.indices.push_back(static_cast<uint32_t>(c.v - 1));
          corner_vn.push_back(c.vn);
          corner_vt.push_back(c.vt);
          pending_line.push_back(line_no);
          any_normal_ref |= c.vn != 0;
          any_uv_ref |= c.vt != 0;
        }
        tri_group.push_back(group);
      }
    } else if (key == "g" || key == "o") {
      std::string name = clean_name(trim(line.substr(line.find(key[0]) + 1)));
      auto [it, inserted] = group_of.emplace(name, static_cast<uint32_t>(names.size()));
      if (inserted) names.push_back(name);
      group = it->second;
    }
    // vp, s, l, p, usemtl, mtllib, cstype ... carry nothing a Mesh holds.
  }

  // Positive indices may name vertices that come later in the file, so check them at the end.
  for (size_t i = 0; i < mesh.indices.size(); ++i) {
    if (mesh.indices[i] >= mesh.positions.size())
      return error(pending_line[i], "vertex index " + std::to_string(uint64_t{mesh.indices[i]} + 1) +
                                        " is out of range (" + std::to_string(mesh.positions.size()) + " vertices)");
    if (corner_vt[i] > static_cast<long long>(vt.size()))
      return error(pending_line[i], "texture index " + std::to_string(corner_vt[i]) + " is out of range (" +
                                        std::to_string(vt.size()) + " texture coordinates)");
    if (corner_vn[i] > static_cast<long long>(vn.size()))
      return error(pending_line[i], "normal index " + std::to_string(corner_vn[i]) + " is out of range (" +
                                        std::to_string(vn.size()) + " normals)");
  }
  resolve_corner_attributes(mesh, vn, vt, corner_vn, corner_vt, any_normal_ref, any_uv_ref);
  detail::gather_parts(mesh, tri_group, names);
  return mesh;
}

}  // namespace mimic::avatar
