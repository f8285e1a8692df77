#include "mimic/avatar/mesh_io.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <filesystem>

#include "mesh_io_internal.h"
#include "mimic/core/file.h"

namespace mimic::avatar {

namespace detail {

void gather_parts(Mesh& mesh, const std::vector<uint32_t>& tri_group, const std::vector<std::string>& names) {
  const size_t tris = tri_group.size();
  std::vector<uint32_t> first_seen_rank(names.size(), UINT32_MAX);
  std::vector<uint32_t> order_of_groups;
  for (uint32_t g : tri_group)
    if (first_seen_rank[g] == UINT32_MAX) {
      first_seen_rank[g] = static_cast<uint32_t>(order_of_groups.size());
      order_of_groups.push_back(g);
    }
  std::vector<uint32_t> count(order_of_groups.size(), 0);
  for (uint32_t g : tri_group) ++count[first_seen_rank[g]];
  std::vector<uint32_t> start(order_of_groups.size() + 1, 0);
  for (size_t r = 0; r < order_of_groups.size(); ++r) start[r + 1] = start[r] + count[r];

  bool already_sorted = true;
  for (size_t t = 1; t < tris; ++t)
    if (first_seen_rank[tri_group[t]] < first_seen_rank[tri_group[t - 1]]) already_sorted = false;
  if (!already_sorted) {
    std::vector<uint32_t> sorted(mesh.indices.size());
    std::vector<uint32_t> fill(start.begin(), start.end() - 1);
    for (size_t t = 0; t < tris; ++t) {
      const uint32_t dst = fill[first_seen_rank[tri_group[t]]]++;
      std::copy_n(mesh.indices.begin() + 3 * t, 3, sorted.begin() + 3 * dst);
    }
    mesh.indices = std::move(sorted);
  }
  mesh.parts.clear();
  for (size_t r = 0; r < order_of_groups.size(); ++r)
    mesh.parts.push_back({names[order_of_groups[r]], start[r], count[r]});
}

glm::vec3 unit_or_up(glm::vec3 n) {
  const float len = glm::length(n);
  if (!(len > 1e-20f) || !std::isfinite(len)) return {0, 1, 0};
  return n / len;
}

std::string lower_extension(const std::string& path) {
  std::string ext = std::filesystem::path(path).extension().string();
  for (auto& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return ext;
}

}  // namespace detail

Status validate_mesh(const Mesh& mesh) {
  if (mesh.indices.size() % 3 != 0)
    return fail(Errc::invalid_argument,
                "mesh index count " + std::to_string(mesh.indices.size()) + " is not a multiple of 3");
  if (!mesh.normals.empty() && mesh.normals.size() != mesh.positions.size())
    return fail(Errc::invalid_argument, "mesh has " + std::to_string(mesh.normals.size()) + " normals for " +
                                            std::to_string(mesh.positions.size()) + " positions");
  if (!mesh.uvs.empty() && mesh.uvs.size() != mesh.positions.size())
    return fail(Errc::invalid_argument, "mesh has " + std::to_string(mesh.uvs.size()) + " texture coordinates for " +
                                            std::to_string(mesh.positions.size()) + " positions");
  // Every writer stores 32-bit floats: a value that is not one could not be read back.
  const auto finite = [](auto v) {
    for (int k = 0; k < v.length(); ++k)
      if (!std::isfinite(v[k])) return false;
    return true;
  };
  for (size_t i = 0; i < mesh.positions.size(); ++i)
    if (!finite(mesh.positions[i]))
      return fail(Errc::invalid_argument, "mesh vertex " + std::to_string(i) + " is not finite");
  for (size_t i = 0; i < mesh.uvs.size(); ++i)
    if (!finite(mesh.uvs[i]))
      return fail(Errc::invalid_argument, "mesh texture coordinate " + std::to_string(i) + " is not finite");
  for (size_t i = 0; i < mesh.indices.size(); ++i)
    if (mesh.indices[i] >= mesh.positions.size())
      return fail(Errc::invalid_argument, "mesh index " + std::to_string(i) + " = " + std::to_string(mesh.indices[i]) +
                                              " is out of range (" + std::to_string(mesh.positions.size()) +
                                              " positions)");
  uint64_t next = 0;
  for (const auto& p : mesh.parts) {
    const uint64_t end = uint64_t{p.first_triangle} + p.triangle_count;
    if (p.first_triangle < next || end > mesh.triangle_count())
      return fail(Errc::invalid_argument,
                  "mesh part '" + p.name + "' overlaps another part or runs past the triangles");
    next = end;
  }
  return {};
}

void scale_mesh(Mesh& mesh, float metres_per_unit) {
  for (auto& p : mesh.positions) p *= metres_per_unit;
}

Status write_mesh(const Mesh& mesh, const std::string& path) {
  const std::string ext = detail::lower_extension(path);
  Result<std::string> bytes = fail(Errc::unsupported, "");
  if (ext == ".obj")
    bytes = encode_obj(mesh);
  else if (ext == ".ply")
    bytes = encode_ply(mesh);
  else if (ext == ".glb")
    bytes = encode_glb(mesh);
  else
    return fail(Errc::unsupported,
                "cannot write mesh '" + path + "': unknown extension '" + ext + "' (use .obj, .ply or .glb)");
  if (!bytes) return tl::unexpected(bytes.error());
  return write_file_atomic(path, *bytes);
}

namespace {

template <class Parse>
Result<Mesh> read_with(const std::string& path, float metres_per_unit, Parse parse) {
  auto bytes = read_file(path);
  if (!bytes) return tl::unexpected(bytes.error());
  auto mesh = parse(*bytes, path);
  if (!mesh || metres_per_unit == 1.0f) return mesh;
  scale_mesh(*mesh, metres_per_unit);
  if (auto ok = validate_mesh(*mesh); !ok) {  // a huge unit can overflow a float
    char scale[32];
    std::snprintf(scale, sizeof scale, "%g", double(metres_per_unit));
    return fail(Errc::invalid_argument, path + ": after scaling by " + scale + " m per unit: " + ok.error().message);
  }
  return mesh;
}

}  // namespace

Result<Mesh> read_obj(const std::string& path, float metres_per_unit) {
  return read_with(path, metres_per_unit, [](std::string_view b, std::string_view s) { return parse_obj(b, s); });
}
Result<Mesh> read_ply(const std::string& path, float metres_per_unit) {
  return read_with(path, metres_per_unit, [](std::string_view b, std::string_view s) { return parse_ply(b, s); });
}
Result<Mesh> read_glb(const std::string& path, float metres_per_unit) {
  return read_with(path, metres_per_unit, [](std::string_view b, std::string_view s) { return parse_glb(b, s); });
}

Result<Mesh> read_mesh(const std::string& path, float metres_per_unit) {
  const std::string ext = detail::lower_extension(path);
  if (ext == ".obj") return read_obj(path, metres_per_unit);
  if (ext == ".ply") return read_ply(path, metres_per_unit);
  if (ext == ".glb") return read_glb(path, metres_per_unit);
  return fail(Errc::unsupported,
              "cannot read mesh '" + path + "': unknown extension '" + ext + "' (use .obj, .ply or .glb)");
}

}  // namespace mimic::avatar
