/* A block dropped under gravity through the C API: its mean height comes down as symplectic
 * Euler's sum over the substeps the scene took (v += g h, then y -= v h; g t^2 / 2 as h goes
 * to 0); the grid's walls are far. Exits 1 otherwise. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>

#include "mpm/mpm_c.h"

#define TRY(call)                                                      \
  do {                                                                 \
    if ((call) != MPM_OK) {                                            \
      fprintf(stderr, "%s failed: %s\n", #call, mpm_last_error());     \
      return 1;                                                        \
    }                                                                  \
  } while (0)

static double meanY(const mpm_vec3* x, size_t n) {
  double y = 0;
  for (size_t i = 0; i < n; ++i) y += x[i].y;
  return y / (double)n;
}

int main(void) {
  mpm_scene_settings settings;
  mpm_scene_settings_default(&settings);
  settings.domain_lower = (mpm_vec3){-0.3f, -0.3f, -0.3f};
  settings.domain_upper = (mpm_vec3){0.3f, 0.5f, 0.3f};
  settings.dx = 0.02f;
  settings.backend = MPM_BACKEND_CPU;
  mpm_scene* scene = NULL;
  TRY(mpm_scene_create(&settings, &scene));

  mpm_object_desc block;
  mpm_object_desc_default(&block);
  block.center = (mpm_vec3){0.f, 0.2f, 0.f};
  block.half_extents = (mpm_vec3){0.05f, 0.05f, 0.05f};
  mpm_object_id id;
  TRY(mpm_scene_add_object(scene, &block, &id));

  size_t n = 0;
  TRY(mpm_scene_particle_count(scene, id, &n));
  mpm_vec3* x = malloc(n * sizeof *x);
  size_t read = 0;
  TRY(mpm_scene_read_positions(scene, id, x, n, &read));
  const double y0 = meanY(x, read);
  const double g = fabs((double)settings.gravity.y);
  double v = 0, expected = 0;
  int substeps = 0;
  for (int i = 0; i < 10; ++i) {
    mpm_step_report report;
    TRY(mpm_scene_step(scene, 0.01f, &report));
    for (int k = 0; k < report.substeps; ++k) {
      v += g * report.substep_dt;
      expected += v * report.substep_dt;
    }
    substeps += report.substeps;
  }
  TRY(mpm_scene_read_positions(scene, id, x, n, &read));
  const double drop = y0 - meanY(x, read);
  free(x);
  mpm_scene_release(scene);

  printf("c_consumer: %zu particles fell %.6f m in %d substeps (expected %.6f m)\n", read, drop, substeps,
         expected);
  /* 0.1 %: float positions and the substeps' lengths rounded to float */
  return fabs(drop - expected) <= 1e-3 * expected ? 0 : 1;
}
