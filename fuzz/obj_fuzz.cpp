// libFuzzer entry point for the mesh readers (OBJ, PLY, GLB): any bytes must either decode into
// a mesh that passes validate_mesh, or fail with a message. A decoded mesh must survive being
// written again in all three formats and read back with the same triangle count.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string_view>

#include "mimic/avatar/mesh_io.h"

namespace {

void check(const mimic::Result<mimic::avatar::Mesh>& mesh) {
  using namespace mimic::avatar;
  if (!mesh) {
    if (mesh.error().message.empty()) std::abort();
    return;
  }
  if (!validate_mesh(*mesh)) std::abort();
  if (mesh->positions.empty()) return;
  const auto obj = encode_obj(*mesh);
  const auto ply = encode_ply(*mesh);
  const auto glb = encode_glb(*mesh);
  if (!obj || !ply || !glb) std::abort();
  const auto a = parse_obj(*obj), b = parse_ply(*ply), c = parse_glb(*glb);
  if (!a || !b || !c) std::abort();
  if (a->triangle_count() != mesh->triangle_count() || b->triangle_count() != mesh->triangle_count() ||
      c->triangle_count() != mesh->triangle_count())
    std::abort();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace mimic::avatar;
  const std::string_view bytes(reinterpret_cast<const char*>(data), size);
  check(parse_obj(bytes, "fuzz.obj"));
  check(parse_ply(bytes, "fuzz.ply"));
  check(parse_glb(bytes, "fuzz.glb"));
  return 0;
}
