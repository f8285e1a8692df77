/* Mimic client library, C ABI: subscribe to a Mimic scene from C or from any language that
 * binds C (a Unity/Godot/Unreal plugin, Python's ctypes, C#'s P/Invoke), without C++.
 *
 *   mimic_options o;
 *   mimic_options_init(&o);
 *   o.server = "127.0.0.1:7777";
 *   o.mesh_lod = 0;                                  (-1: joints only)
 *   mimic_subscriber* s = NULL;
 *   char error[256];
 *   if (mimic_subscriber_connect(&o, &s, error, sizeof error) != MIMIC_OK) { puts(error); ... }
 *   mimic_subscriber_on_mesh(s, upload_vertices, engine);
 *   while (mimic_subscriber_poll(s, error, sizeof error) == MIMIC_OK) { ... render ... }
 *   mimic_subscriber_destroy(s);
 *
 * Handles are opaque; every call returns a status code; strings are NUL-terminated UTF-8 and
 * errors are copied into the caller's buffer. A subscriber is used from one thread; callbacks
 * run inside poll/run_for on that thread, and the views they receive (and every pointer in them)
 * are valid until the callback returns. Receiving a frame does not allocate: the views point into
 * buffers sized when an avatar's model or mesh topology arrives.
 *
 * Frames: metres, +Y up, the body faces +Z, its left is +X (Mimic's world). Orientations are unit
 * quaternions (x, y, z, w), world_from_joint. Triangles are counter-clockwise seen from outside.
 */
#ifndef MIMIC_C_H
#define MIMIC_C_H

#include <stddef.h>
#include <stdint.h>

#if defined(_WIN32)
#define MIMIC_C_API
#else
#define MIMIC_C_API __attribute__((visibility("default")))
#endif

#ifdef __cplusplus
extern "C" {
#endif

typedef enum mimic_status {
  MIMIC_OK = 0,
  MIMIC_ERROR_ARGUMENT = 1,      /* a null handle or pointer, a value out of range */
  MIMIC_ERROR_CONNECT = 2,       /* the server could not be reached, or refused the session */
  MIMIC_ERROR_SESSION_ENDED = 3, /* the session ended for good (the reason is in the error text) */
  MIMIC_ERROR_NOT_FOUND = 4      /* no such avatar, or no mesh yet */
} mimic_status;

typedef struct mimic_vec3 {
  float x, y, z;
} mimic_vec3;

typedef struct mimic_vec2 {
  float u, v;
} mimic_vec2;

typedef struct mimic_quat {
  float x, y, z, w;
} mimic_quat;

typedef struct mimic_joint {
  const char* name;       /* e.g. "pelvis", "l_elbow" */
  int32_t parent;         /* index in the avatar's joints, -1 for the root */
  mimic_vec3 position_m;  /* world position of the joint centre */
  mimic_quat orientation; /* world_from_joint */
} mimic_joint;

typedef struct mimic_avatar {
  uint16_t id;      /* scene-wide */
  const char* name; /* as published, e.g. "avatar1" */
  uint32_t joint_count;
  const mimic_joint* joints; /* parents before children */
  uint32_t dof_count;
  const float* dof_rad; /* the pose frame's joint angles */
  mimic_vec3 root_position_m;
  mimic_quat root_orientation;
  uint32_t sequence; /* of the latest pose frame */
  uint64_t time_us;  /* its capture time, µs since the Unix epoch */
  int32_t stale;     /* the publisher's trackers had no fresh data */
  int32_t has_pose;  /* 0 until the first pose frame (joints at rest until then) */
  uint64_t frames, lost;
} mimic_avatar;

typedef struct mimic_mesh {
  uint16_t avatar;
  int32_t lod;
  uint32_t vertex_count;
  const mimic_vec3* positions_m;
  const mimic_vec3* normals; /* unit, area-weighted */
  uint32_t index_count;      /* 3 per triangle */
  const uint32_t* indices;   /* the same until the topology changes */
  uint32_t sequence;
  uint64_t time_us;
  uint64_t frames;
  /* Texture coordinates, vertex_count of them, the same until the topology changes; NULL when
   * the server sends none. With them the mesh has its seams split (client.h's Mesh). */
  const mimic_vec2* uvs;
} mimic_mesh;

typedef struct mimic_options {
  const char* server;       /* "HOST:PORT"; default "127.0.0.1:7777" */
  const char* name;         /* shown in the server's session list; default "mimic-c" */
  int32_t udp;              /* pose frames as UDP datagrams when offered */
  int32_t mesh_lod;         /* 0..7: also the deformed skin at this LOD; -1 (default): joints only */
  double connect_timeout_s; /* default 3 */
} mimic_options;

typedef struct mimic_subscriber mimic_subscriber;

typedef void (*mimic_avatar_fn)(void* user, const mimic_avatar* avatar);
typedef void (*mimic_mesh_fn)(void* user, const mimic_mesh* mesh);
typedef void (*mimic_removed_fn)(void* user, uint16_t avatar_id);

MIMIC_C_API const char* mimic_version(void);
MIMIC_C_API const char* mimic_status_name(mimic_status status);
MIMIC_C_API void mimic_options_init(mimic_options* options);

/* Connects and completes the handshake (blocking, up to connect_timeout_s). On failure *out is
 * NULL and the reason is in error (when error_bytes > 0). */
MIMIC_C_API mimic_status mimic_subscriber_connect(const mimic_options* options, mimic_subscriber** out, char* error,
                                                  size_t error_bytes);
MIMIC_C_API void mimic_subscriber_destroy(mimic_subscriber* subscriber);

/* Callbacks (NULL to remove); `user` is passed back as is. */
MIMIC_C_API mimic_status mimic_subscriber_on_avatar(mimic_subscriber* s, mimic_avatar_fn fn, void* user);
MIMIC_C_API mimic_status mimic_subscriber_on_frame(mimic_subscriber* s, mimic_avatar_fn fn, void* user);
MIMIC_C_API mimic_status mimic_subscriber_on_mesh(mimic_subscriber* s, mimic_mesh_fn fn, void* user);
MIMIC_C_API mimic_status mimic_subscriber_on_removed(mimic_subscriber* s, mimic_removed_fn fn, void* user);

/* Handles what the network has, without blocking (poll), or for `seconds` (run_for). */
MIMIC_C_API mimic_status mimic_subscriber_poll(mimic_subscriber* s, char* error, size_t error_bytes);
MIMIC_C_API mimic_status mimic_subscriber_run_for(mimic_subscriber* s, double seconds, char* error, size_t error_bytes);

/* The avatars present: writes up to `capacity` ids and sets *count to how many there are. */
MIMIC_C_API mimic_status mimic_subscriber_avatar_ids(const mimic_subscriber* s, uint16_t* ids, size_t capacity,
                                                     size_t* count);
/* The latest state of one avatar, or of its mesh; valid until the next poll or run_for. */
MIMIC_C_API mimic_status mimic_subscriber_avatar(mimic_subscriber* s, uint16_t id, mimic_avatar* out);
MIMIC_C_API mimic_status mimic_subscriber_mesh(mimic_subscriber* s, uint16_t id, mimic_mesh* out);

#ifdef __cplusplus
}
#endif

#endif /* MIMIC_C_H */
