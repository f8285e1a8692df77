/* Subscribes to a Mimic scene's deformed skin and writes each received mesh frame as an OBJ
 * file (vertices, normals, texture coordinates when the server sends them, triangles), as an
 * engine plugin would upload its vertex buffer:
 *
 *   mesh_obj HOST:PORT [--lod L] [--frames N] [--out DIR]     (defaults: LOD 0, 3 frames, .)
 *
 * Files: DIR/avatar<ID>_<SEQUENCE>.obj. Plain C99 over mimic/mimic_c.h. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <mimic/mimic_c.h>

struct state {
  const char* out_dir;
  long written, wanted;
  int failed;
};

static void write_obj(void* user, const mimic_mesh* m) {
  struct state* st = (struct state*)user;
  char path[1024];
  if (st->written >= st->wanted) return;
  snprintf(path, sizeof path, "%s/avatar%u_%u.obj", st->out_dir, (unsigned)m->avatar, (unsigned)m->sequence);
  FILE* f = fopen(path, "w");
  if (!f) {
    fprintf(stderr, "mesh_obj: cannot write %s\n", path);
    st->failed = 1;
    return;
  }
  fprintf(f, "# Mimic avatar %u, LOD %d, mesh frame %u: %u vertices, %u triangles\n", (unsigned)m->avatar, (int)m->lod,
          (unsigned)m->sequence, (unsigned)m->vertex_count, (unsigned)(m->index_count / 3));
  for (uint32_t i = 0; i < m->vertex_count; ++i)
    fprintf(f, "v %.5f %.5f %.5f\n", m->positions_m[i].x, m->positions_m[i].y, m->positions_m[i].z);
  for (uint32_t i = 0; i < m->vertex_count; ++i)
    fprintf(f, "vn %.4f %.4f %.4f\n", m->normals[i].x, m->normals[i].y, m->normals[i].z);
  if (m->uvs)
    for (uint32_t i = 0; i < m->vertex_count; ++i) fprintf(f, "vt %.5f %.5f\n", m->uvs[i].u, m->uvs[i].v);
  for (uint32_t t = 0; t + 2 < m->index_count; t += 3) {
    const uint32_t a = m->indices[t] + 1, b = m->indices[t + 1] + 1, c = m->indices[t + 2] + 1;
    if (m->uvs)
      fprintf(f, "f %u/%u/%u %u/%u/%u %u/%u/%u\n", a, a, a, b, b, b, c, c, c);
    else
      fprintf(f, "f %u//%u %u//%u %u//%u\n", a, a, b, b, c, c);
  }
  fclose(f);
  printf("%s\n", path);
  fflush(stdout);
  st->written++;
}

int main(int argc, char** argv) {
  mimic_options options;
  mimic_options_init(&options);
  options.mesh_lod = 0;
  struct state st = {".", 0, 3, 0};
  for (int i = 1; i < argc; ++i) {
    if (strcmp(argv[i], "--lod") == 0 && i + 1 < argc) {
      options.mesh_lod = atoi(argv[++i]);
    } else if (strcmp(argv[i], "--frames") == 0 && i + 1 < argc) {
      st.wanted = strtol(argv[++i], NULL, 10);
    } else if (strcmp(argv[i], "--out") == 0 && i + 1 < argc) {
      st.out_dir = argv[++i];
    } else if (argv[i][0] != '-') {
      options.server = argv[i];
    } else {
      fprintf(stderr, "usage: mesh_obj HOST:PORT [--lod L] [--frames N] [--out DIR]\n");
      return 2;
    }
  }
  char error[512];
  mimic_subscriber* sub = NULL;
  mimic_status s = mimic_subscriber_connect(&options, &sub, error, sizeof error);
  if (s != MIMIC_OK) {
    fprintf(stderr, "mesh_obj: %s: %s\n", mimic_status_name(s), error);
    return 1;
  }
  mimic_subscriber_on_mesh(sub, write_obj, &st);
  for (int i = 0; i < 3000 && st.written < st.wanted && !st.failed; ++i) {
    s = mimic_subscriber_run_for(sub, 0.01, error, sizeof error);
    if (s != MIMIC_OK) {
      fprintf(stderr, "mesh_obj: %s: %s\n", mimic_status_name(s), error);
      break;
    }
  }
  mimic_subscriber_destroy(sub);
  return st.written == st.wanted && !st.failed ? 0 : 1;
}
