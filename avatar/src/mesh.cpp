#include "mimic/avatar/mesh.h"

namespace mimic::avatar {

std::vector<MeshPart> covering_parts(const Mesh& mesh) {
  std::vector<MeshPart> out;
  const auto tris = static_cast<uint32_t>(mesh.triangle_count());
  uint32_t next = 0;
  for (const auto& p : mesh.parts) {
    if (p.first_triangle > next) out.push_back({"mesh", next, p.first_triangle - next});
    out.push_back({clean_name(p.name), p.first_triangle, p.triangle_count});
    next = p.first_triangle + p.triangle_count;
  }
  if (next < tris) out.push_back({"mesh", next, tris - next});
  return out;
}

std::string clean_name(std::string_view name) {
  std::string s;
  for (char c : name) s += (static_cast<unsigned char>(c) < 0x20 || c == 0x7f) ? '_' : c;
  while (!s.empty() && s.back() == ' ') s.pop_back();
  while (!s.empty() && s.front() == ' ') s.erase(s.begin());
  return s.empty() ? "mesh" : s;
}

}  // namespace mimic::avatar
