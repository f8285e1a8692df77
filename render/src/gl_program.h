// Shader programs from GLSL source, for the renderer's passes (render/src only).
#pragma once

#include <GL/gl.h>
#include <GL/glext.h>

#include "mimic/core/result.h"

namespace mimic::render::detail {

// A linked program of a vertex and a fragment shader; the error carries the driver's log.
Result<GLuint> link_program(const char* vertex_source, const char* fragment_source);

inline const void* buffer_offset(size_t bytes) { return reinterpret_cast<const void*>(bytes); }

}  // namespace mimic::render::detail
