// Mesh files: Wavefront OBJ, binary PLY and glTF 2.0 binary (.glb), written from and read into
// avatar::Mesh (metres, +Y up, counter-clockwise triangles seen from outside).
//
// What each format keeps:
//   OBJ  `o mimic_body`, one `g <part>` per part, `v` positions, `vn` normals and `vt` texture
//        coordinates (when the mesh has them), `f a/a/a …` triangles (1-based).
//   PLY  binary_little_endian 1.0; vertex x y z [nx ny nz] [s t] (float); face `list uchar int
//        vertex_indices` plus `ushort part`; part names in `comment part <id> <name>` lines.
//   GLB  one mesh whose primitives are the parts (shared POSITION/NORMAL/TEXCOORD_0 accessors,
//        one index accessor per part, part name in the primitive's extras.name), one node
//        "mimic_body", asset.generator "Mimic". Empty parts are left out (glTF accessors cannot
//        be empty). With texture coordinates each part gets its own material, a generated
//        checker PNG in the part's colour (TEXCOORD_0 holds (u, 1 − v): glTF's origin is the
//        image's top-left).
//
// Readers never crash on bad input: malformed data is a parse_error naming the file and the
// line (text) or byte offset (binary). Polygons are fan-triangulated. Parts come from OBJ
// g/o lines, PLY `part` properties, glTF primitives; triangles of a part named more than once
// are gathered into one contiguous part (in order of first appearance). A file without parts
// gives one part named "mesh". Writing is atomic (the file is complete or untouched).
#pragma once

#include <string>
#include <string_view>

#include "mimic/avatar/mesh.h"
#include "mimic/core/result.h"

namespace mimic::avatar {

// Picks the format by extension (.obj, .ply, .glb; case-insensitive). Fails with
// invalid_argument for an index out of range or a part range outside the triangles, with
// unsupported for another extension, io_error when the file cannot be written.
Status write_mesh(const Mesh& mesh, const std::string& path);
// Reads .obj, .ply or .glb by extension; positions are scaled by metres_per_unit.
Result<Mesh> read_mesh(const std::string& path, float metres_per_unit = 1.0f);

// Encoders: the exact bytes write_mesh stores. Fail as write_mesh does for a bad mesh.
Result<std::string> encode_obj(const Mesh& mesh);
Result<std::string> encode_ply(const Mesh& mesh);
Result<std::string> encode_glb(const Mesh& mesh);

// Decoders of a whole file's bytes; `source` names the file in error messages.
// OBJ: v (x y z [w]), vn, vt (u [v [w]]), f with v, v/vt, v//vn, v/vt/vn and negative (relative)
// indices; vp, s, l, p, usemtl, mtllib and unknown statements are ignored; CRLF accepted.
// Normals and texture coordinates are kept when faces reference them (first reference wins at
// a shared vertex).
Result<Mesh> parse_obj(std::string_view text, std::string_view source = "obj");
// PLY: ascii or binary_little_endian, any scalar types, other elements skipped.
Result<Mesh> parse_ply(std::string_view bytes, std::string_view source = "ply");
// GLB: the first mesh's triangle primitives (indexed or not); unsigned byte/short/int indices.
Result<Mesh> parse_glb(std::string_view bytes, std::string_view source = "glb");

Result<Mesh> read_obj(const std::string& path, float metres_per_unit = 1.0f);
Result<Mesh> read_ply(const std::string& path, float metres_per_unit = 1.0f);
Result<Mesh> read_glb(const std::string& path, float metres_per_unit = 1.0f);

// Multiplies every position by metres_per_unit (e.g. 0.1 for decimetre files).
void scale_mesh(Mesh& mesh, float metres_per_unit);

// Checks the invariants the writers rely on: indices in range, a multiple of 3, normals and uvs
// empty or one per position, parts within the triangles and in order without overlap.
Status validate_mesh(const Mesh& mesh);

}  // namespace mimic::avatar
