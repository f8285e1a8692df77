// The shipped rigid meshes (rigid_mesh_store.h): decoding, carrying onto another primitive set,
// and writing the table.
#include "rigid_mesh_store.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <vector>

#include <glm/gtx/euler_angles.hpp>

namespace mimic::avatar::skin_detail {

namespace {

constexpr char kBase64[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";

std::vector<uint8_t> base64_decode(const char* s) {
  std::array<int, 256> value;
  value.fill(-1);
  for (int i = 0; i < 64; ++i) value[static_cast<uint8_t>(kBase64[i])] = i;
  std::vector<uint8_t> out;
  uint32_t bits = 0;
  int count = 0;
  for (; *s; ++s) {
    const int v = value[static_cast<uint8_t>(*s)];
    if (v < 0) continue;  // padding
    bits = (bits << 6) | static_cast<uint32_t>(v), count += 6;
    if (count >= 8) count -= 8, out.push_back(static_cast<uint8_t>(bits >> count));
  }
  return out;
}

std::string base64_encode(const std::vector<uint8_t>& bytes) {
  std::string out;
  uint32_t bits = 0;
  int count = 0;
  for (uint8_t b : bytes) {
    bits = (bits << 8) | b, count += 8;
    while (count >= 6) count -= 6, out.push_back(kBase64[(bits >> count) & 63]);
  }
  if (count > 0) out.push_back(kBase64[(bits << (6 - count)) & 63]);
  while (out.size() % 4) out.push_back('=');
  return out;
}

RigidPart mirror_of(RigidPart p) {
  switch (p) {
    case RigidPart::left_hand: return RigidPart::right_hand;
    case RigidPart::right_hand: return RigidPart::left_hand;
    case RigidPart::left_foot: return RigidPart::right_foot;
    case RigidPart::right_foot: return RigidPart::left_foot;
    default: return p;
  }
}

glm::mat3 rotation_of(const float* orientation_rad) {
  return glm::mat3(glm::eulerAngleZ(orientation_rad[2]) * glm::eulerAngleY(orientation_rad[1]) *
                   glm::eulerAngleX(orientation_rad[0]));
}

StoredPrimitive signature(const Primitive& p) {
  const PrimitiveState& s = p.state;
  return {static_cast<int>(p.kind),
          {s.center_m.x, s.center_m.y, s.center_m.z},
          {s.semi_axes_m.x, s.semi_axes_m.y, s.semi_axes_m.z},
          {s.orientation_rad.x, s.orientation_rad.y, s.orientation_rad.z},
          p.weight,
          p.influence};
}

bool same(const StoredPrimitive& a, const StoredPrimitive& b) {
  auto near = [](const float* x, const float* y, int n, float tol) {
    for (int i = 0; i < n; ++i)
      if (!(std::abs(x[i] - y[i]) <= tol)) return false;
    return true;
  };
  return a.kind == b.kind && near(a.center_m, b.center_m, 3, 1e-6f) && near(a.semi_axes_m, b.semi_axes_m, 3, 1e-6f) &&
         near(a.orientation_rad, b.orientation_rad, 3, 1e-6f) && near(&a.weight, &b.weight, 1, 1e-6f) &&
         near(&a.influence, &b.influence, 1, 1e-6f);
}

glm::dvec3 center_of(const StoredPrimitive& p) { return {p.center_m[0], p.center_m[1], p.center_m[2]}; }

// The primitive's principal axes in its joint's frame, each scaled by its semi-axis (columns).
glm::dmat3 axes_of(const StoredPrimitive& p) {
  const glm::mat3 r = rotation_of(p.orientation_rad);
  glm::dmat3 u;
  for (int k = 0; k < 3; ++k) u[k] = glm::dvec3(r[k]) * static_cast<double>(p.semi_axes_m[k]);
  return u;
}

// `to`'s axes with each sign chosen to agree with `a` carrying `from`'s (an axis's sign is free).
glm::dmat3 axes_along(const glm::dmat3& from, glm::dmat3 to, const glm::dmat3& a) {
  for (int k = 0; k < 3; ++k)
    if (glm::dot(a * from[k], to[k]) < 0) to[k] = -to[k];
  return to;
}

// The affine map (x → a·x + t) that best takes the stored primitives onto `to`: their centres
// about their means, and their axes scaled by their semi-axes (signs as the centres' map has
// them). nullopt when the centres span no volume.
struct Affine {
  glm::dmat3 a;
  glm::dvec3 t;
  bool exact = false;  // a rigid motion or mirror that lands every centre and axis within a micrometre
};
std::optional<Affine> fit_affine(std::span<const StoredPrimitive> from, std::span<const StoredPrimitive> to) {
  const size_t n = from.size();
  glm::dvec3 mean_from(0.0), mean_to(0.0);
  for (size_t i = 0; i < n; ++i) mean_from += center_of(from[i]), mean_to += center_of(to[i]);
  mean_from /= static_cast<double>(n), mean_to /= static_cast<double>(n);
  glm::dmat3 cross(0.0), gram(0.0);
  auto add = [&](const glm::dvec3& u, const glm::dvec3& v) {
    cross += glm::outerProduct(v, u), gram += glm::outerProduct(u, u);
  };
  for (size_t i = 0; i < n; ++i) add(center_of(from[i]) - mean_from, center_of(to[i]) - mean_to);
  if (!(std::abs(glm::determinant(gram)) > 1e-15)) return std::nullopt;
  const glm::dmat3 by_centres = cross * glm::inverse(gram);
  for (size_t i = 0; i < n; ++i) {
    const glm::dmat3 u = axes_of(from[i]), v = axes_along(u, axes_of(to[i]), by_centres);
    for (int k = 0; k < 3; ++k) add(u[k], v[k]);
  }
  const glm::dmat3 a = cross * glm::inverse(gram);
  Affine map{a, mean_to - a * mean_from};
  double worst = 0;
  for (size_t i = 0; i < n; ++i) {
    worst = std::max(worst, glm::length(a * center_of(from[i]) + map.t - center_of(to[i])));
    const glm::dmat3 u = axes_of(from[i]), v = axes_along(u, axes_of(to[i]), a);
    for (int k = 0; k < 3; ++k) worst = std::max(worst, glm::length(a * u[k] - v[k]));
    worst = std::max({worst, std::abs(double(from[i].weight) - to[i].weight),
                      std::abs(double(from[i].influence) - to[i].influence)});
  }
  map.exact = worst < 1e-6 && std::abs(std::abs(glm::determinant(a)) - 1.0) < 1e-6;
  return map;
}

// Each stored primitive's own affine map onto its counterpart (centre onto centre, its axes onto
// the counterpart's, signs as the whole map has them), and its field's support, to weigh it by
// at a stored point.
struct PrimitiveMap {
  glm::dmat3 unit_from_stored;  // S⁻¹ Rᵀ of the stored primitive
  glm::dvec3 stored_center, center;
  glm::dmat3 a;
  double influence2, weight;
};

std::vector<PrimitiveMap> primitive_maps(std::span<const StoredPrimitive> from, std::span<const StoredPrimitive> to,
                                         const glm::dmat3& whole) {
  std::vector<PrimitiveMap> maps;
  for (size_t i = 0; i < from.size(); ++i) {
    const glm::dmat3 u = axes_of(from[i]), v = axes_along(u, axes_of(to[i]), whole);
    if (!(std::abs(glm::determinant(u)) > 1e-18)) continue;
    maps.push_back({glm::inverse(u), center_of(from[i]), center_of(to[i]), v * glm::inverse(u),
                    static_cast<double>(from[i].influence) * from[i].influence, static_cast<double>(from[i].weight)});
  }
  return maps;
}

// A stored point moved by the primitives' maps, each weighted by its field there (the metaball
// falloff (1 − d²/r²)³): a primitive the fit moved on its own takes its part of the surface with
// it. Outside every support, by the whole map.
glm::vec3 blend_carry(const glm::vec3& x, std::span<const PrimitiveMap> maps, const Affine& whole) {
  glm::dvec3 sum(0.0);
  double total = 0;
  for (const PrimitiveMap& m : maps) {
    const glm::dvec3 d = glm::dvec3(x) - m.stored_center, unit = m.unit_from_stored * d;
    const double q = 1.0 - glm::dot(unit, unit) / m.influence2;
    if (q <= 0) continue;
    const double w = m.weight * q * q * q;
    sum += w * (m.center + m.a * d), total += w;
  }
  return total > 1e-12 ? glm::vec3(sum / total) : glm::vec3(whole.a * glm::dvec3(x) + whole.t);
}

// The stored mesh carried onto the part's primitives and projected onto f; nullopt when a vertex
// stays off the surface or a triangle turns over.
std::optional<IsoMesh> carry(IsoMesh m, std::span<const StoredPrimitive> from, std::span<const StoredPrimitive> to,
                             const Affine& map, const IsoField& f) {
  const bool mirrored = glm::determinant(map.a) < 0;
  if (mirrored)
    for (size_t i = 0; i < m.triangles.size(); i += 3) std::swap(m.triangles[i + 1], m.triangles[i + 2]);
  if (map.exact) {  // a rigid motion or mirror of the stored field: its mesh is the stored one moved
    for (glm::vec3& p : m.positions) p = glm::vec3(map.a * glm::dvec3(p) + map.t);
    return m;
  }
  const std::vector<PrimitiveMap> maps = primitive_maps(from, to, map.a);
  for (glm::vec3& p : m.positions) p = blend_carry(p, maps, map);
  const std::vector<glm::vec3> carried = m.positions;
  constexpr float kMaxStep_m = 0.003f, kOnSurface_m = 2e-4f, kGradientStep_m = 1e-4f;
  for (glm::vec3& p : m.positions) {
    p = project_to_iso(f, project_to_iso(f, p, kMaxStep_m), kMaxStep_m);
    const glm::vec3 g = f.gradient(p, kGradientStep_m);
    const float slope = glm::length(g);
    if (!(slope > 0.0f) || !(std::abs(f.value(p) - f.iso) / slope < kOnSurface_m)) return std::nullopt;
  }
  auto normal = [&m](const std::vector<glm::vec3>& pos, size_t t) {
    const glm::vec3 a = pos[m.triangles[t]], b = pos[m.triangles[t + 1]], c = pos[m.triangles[t + 2]];
    return glm::cross(b - a, c - a);
  };
  for (size_t t = 0; t < m.triangles.size(); t += 3) {
    const glm::vec3 before = normal(carried, t), after = normal(m.positions, t);
    // Turned by more than 60°, or collapsed.
    if (!(glm::dot(before, after) > 0.5f * glm::length(before) * glm::length(after)) || !(glm::length(after) > 0))
      return std::nullopt;
  }
  return m;
}

}  // namespace

IsoMesh decode(const StoredRigidMesh& s) {
  const std::vector<uint8_t> bytes = base64_decode(s.base64);
  IsoMesh m;
  if (bytes.size() < 6 * (s.vertex_count + s.triangle_count)) return m;
  auto u16 = [&bytes](size_t i) { return static_cast<uint16_t>(bytes[2 * i] | (bytes[2 * i + 1] << 8)); };
  m.positions.resize(s.vertex_count);
  for (size_t v = 0; v < s.vertex_count; ++v)
    for (int k = 0; k < 3; ++k) m.positions[v][k] = static_cast<float>(static_cast<int16_t>(u16(3 * v + k))) * s.step_m;
  m.triangles.resize(3 * s.triangle_count);
  for (size_t i = 0; i < m.triangles.size(); ++i) m.triangles[i] = u16(3 * s.vertex_count + i);
  return m;
}

std::optional<IsoMesh> rigid_mesh_from_store(RigidPart part, const BodyModel& model, const IsoField& f, size_t budget,
                                             int smoothing) {
  std::vector<StoredPrimitive> own;
  for (const Primitive& p : model.primitives)
    if (p.part == part) {
      if (p.deformation) return std::nullopt;  // a rigid part whose shape changes: not a stored mesh's
      own.push_back(signature(p));
    }
  // The stored meshes are in order of part, then budget from the largest: the last that fits
  // the budget needs the least simplifying.
  const StoredRigidMesh* best = nullptr;
  for (const StoredRigidMesh& s : stored_rigid_meshes()) {
    if ((s.part != part && s.part != mirror_of(part)) || s.primitive_count != own.size() || budget > s.budget) continue;
    const std::span<const StoredPrimitive> stored(s.primitives, s.primitive_count);
    if (!std::equal(stored.begin(), stored.end(), own.begin(),
                    [](const StoredPrimitive& a, const StoredPrimitive& b) { return a.kind == b.kind; }))
      continue;
    // The mirror's only when the part itself is not stored.
    if (!best || (best->part != part && s.part == part) || (best->part == s.part && s.budget < best->budget)) best = &s;
  }
  if (!best) return std::nullopt;
  const std::span<const StoredPrimitive> stored(best->primitives, best->primitive_count);
  std::optional<IsoMesh> m;
  if (best->part == part && std::equal(stored.begin(), stored.end(), own.begin(), same)) {
    m = decode(*best);
  } else if (const auto map = fit_affine(stored, own)) {
    m = carry(decode(*best), stored, own, *map, f);
  }
  if (m && budget < best->budget) decimate(*m, f, budget, smoothing);
  return m;
}

namespace {

// A float as a C++ float literal that reads back to the same value (9 significant digits).
std::string float_literal(float v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.9g", static_cast<double>(v));
  std::string out = buf;
  if (out.find_first_of(".en") == std::string::npos) out += ".0";
  return out + "f";
}

// The part's primitives as a C++ array named k_PART_primitives.
std::string primitives_source(const BodyModel& model, RigidPart part) {
  std::string out = std::string("constexpr StoredPrimitive k_") + rigid_part_name(part) + "_primitives[] = {\n";
  for (const Primitive& p : model.primitives) {
    if (p.part != part) continue;
    const StoredPrimitive s = signature(p);
    auto three = [&out](const float* v) {
      out += '{';
      for (int k = 0; k < 3; ++k) out += (k ? ", " : "") + float_literal(v[k]);
      out += "}, ";
    };
    out += "    {" + std::to_string(s.kind) + ", ";
    three(s.center_m);
    three(s.semi_axes_m);
    three(s.orientation_rad);
    out += float_literal(s.weight) + ", " + float_literal(s.influence) + "},\n";
  }
  return out + "};\n\n";
}

// The mesh as a base64 string literal named `name`; its position step through `step`.
std::string mesh_source(const IsoMesh& m, const std::string& name, float& step) {
  // Steps of 10 µm (int16 holds ±0.33 m about the joint), wider for a part that reaches farther.
  float reach = 0;
  for (const glm::vec3& p : m.positions) reach = std::max({reach, std::abs(p.x), std::abs(p.y), std::abs(p.z)});
  step = std::max(1e-5f, reach / 32000.0f);
  std::vector<uint8_t> bytes;
  auto put16 = [&bytes](uint16_t v) {
    bytes.push_back(static_cast<uint8_t>(v & 0xff)), bytes.push_back(static_cast<uint8_t>(v >> 8));
  };
  for (const glm::vec3& p : m.positions)
    for (int k = 0; k < 3; ++k) put16(static_cast<uint16_t>(static_cast<int16_t>(std::lround(p[k] / step))));
  for (uint32_t i : m.triangles) put16(static_cast<uint16_t>(i));
  const std::string b64 = base64_encode(bytes);
  std::string out = "constexpr char " + name + "[] =\n";
  for (size_t i = 0; i < b64.size(); i += 96) out += "    \"" + b64.substr(i, 96) + "\"\n";
  return out + "    ;\n\n";
}

}  // namespace

std::string rigid_mesh_table_source(const BodyModel& model, std::span<const MeshToStore> meshes) {
  std::string out =
      "// Generated by `mimic mesh --emit-rigid-meshes avatar/src/skin/rigid_mesh_table.cpp`\n"
      "// (scripts/regen_rigid_meshes.sh): the built-in body's rigid parts meshed from their field at\n"
      "// each LOD's budget (rigid_mesh_store.h). Do not edit.\n"
      "#include \"rigid_mesh_store.h\"\n\nnamespace mimic::avatar::skin_detail {\n\nnamespace {\n\n";
  std::string table;
  char buf[512];
  for (size_t i = 0; i < meshes.size(); ++i) {
    const MeshToStore& e = meshes[i];
    const std::string part = rigid_part_name(e.part), name = "k_" + part + "_" + std::to_string(e.budget);
    if (i == 0 || meshes[i - 1].part != e.part) out += primitives_source(model, e.part);
    float step = 0;
    out += mesh_source(e.mesh, name, step);
    const auto count = std::count_if(model.primitives.begin(), model.primitives.end(),
                                     [&e](const Primitive& p) { return p.part == e.part; });
    std::snprintf(buf, sizeof buf, "    {RigidPart::%s, k_%s_primitives, %zu, %zu, %zu, %zu, %s, %s},\n", part.c_str(),
                  part.c_str(), static_cast<size_t>(count), e.budget, e.mesh.positions.size(),
                  e.mesh.triangles.size() / 3, float_literal(step).c_str(), name.c_str());
    table += buf;
  }
  out += "constexpr StoredRigidMesh kMeshes[] = {\n" + table + "};\n\n}  // namespace\n\n";
  out += "std::span<const StoredRigidMesh> stored_rigid_meshes() { return kMeshes; }\n\n";
  return out + "}  // namespace mimic::avatar::skin_detail\n";
}

}  // namespace mimic::avatar::skin_detail
