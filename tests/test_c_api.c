/* The C API (mpm/mpm_c.h) from C: a scene driven through it, with its physics checked
 * against the closed form and every error path named. Prints what it checks; exits 1 on
 * the first failure. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "mpm/mpm_c.h"

static int failures = 0;
#define CHECK(cond, ...)                                    \
  do {                                                      \
    if (!(cond)) {                                          \
      printf("FAILED %s:%d: %s: ", __FILE__, __LINE__, #cond); \
      printf(__VA_ARGS__);                                  \
      printf("\n");                                         \
      ++failures;                                           \
    }                                                       \
  } while (0)

/* A call that must fail with `status` and a message containing `needle`. */
static void expectError(mpm_status got, mpm_status status, const char* needle) {
  CHECK(got == status, "status %d, expected %d (%s)", (int)got, (int)status, mpm_last_error());
  CHECK(strstr(mpm_last_error(), needle) != NULL, "message \"%s\" does not name \"%s\"", mpm_last_error(), needle);
  printf("  refused as expected: %s\n", mpm_last_error());
}

static mpm_scene_settings settings(void) {
  mpm_scene_settings s;
  mpm_scene_settings_default(&s);
  s.domain_lower = (mpm_vec3){-0.3f, -0.3f, -0.3f};
  s.domain_upper = (mpm_vec3){0.3f, 0.5f, 0.3f};
  s.dx = 0.02f;
  s.backend = MPM_BACKEND_CPU;
  return s;
}

static double meanY(const mpm_vec3* x, size_t n) {
  double y = 0;
  for (size_t i = 0; i < n; ++i) y += x[i].y;
  return y / (double)n;
}

int main(void) {
  /* --- errors before a scene exists: each names its field and value --- */
  mpm_scene* scene = NULL;
  mpm_scene_settings s = settings();
  s.dx = 0.f;
  expectError(mpm_scene_create(&s, &scene), MPM_ERROR_INVALID_ARGUMENT, "dx = 0");
  CHECK(scene == NULL, "no scene on failure");
  s = settings();
  s.solver = 7;
  expectError(mpm_scene_create(&s, &scene), MPM_ERROR_INVALID_ARGUMENT, "mpm_scene_settings.solver = 7");
  s.solver = MPM_SOLVER_MLS;
  s.backend = -1;
  expectError(mpm_scene_create(&s, &scene), MPM_ERROR_INVALID_ARGUMENT, "mpm_scene_settings.backend = -1");
  expectError(mpm_scene_create(NULL, &scene), MPM_ERROR_INVALID_ARGUMENT, "settings = NULL");

  s = settings();
  CHECK(mpm_scene_create(&s, &scene) == MPM_OK, "%s", mpm_last_error());
  if (!scene) return 1;

  /* --- a block in free fall: 10 cm cube of 20 kPa tissue, 0.1 s --- */
  mpm_object_desc block;
  mpm_object_desc_default(&block);
  block.center = (mpm_vec3){0.f, 0.2f, 0.f};
  block.half_extents = (mpm_vec3){0.05f, 0.05f, 0.05f};
  block.material.model = MPM_NEO_HOOKEAN_DECOUPLED;
  block.material.youngs_modulus = 2e4f;
  block.material.poisson_ratio = 0.7f;
  mpm_object_id id;
  expectError(mpm_scene_add_object(scene, &block, &id), MPM_ERROR_INVALID_ARGUMENT, "poissonRatio = 0.7");
  block.material.poisson_ratio = 0.3f;
  block.material.model = 5;
  expectError(mpm_scene_add_object(scene, &block, &id), MPM_ERROR_INVALID_ARGUMENT, "material.model = 5");
  block.material.model = MPM_NEO_HOOKEAN_DECOUPLED;
  CHECK(mpm_scene_add_object(scene, &block, &id) == MPM_OK, "%s", mpm_last_error());

  size_t n = 0, count = 0;
  CHECK(mpm_scene_particle_count(scene, id, &n) == MPM_OK && n == 1000, "particles %zu, expected 10^3", n);
  mpm_vec3* x = malloc(n * sizeof *x);
  mpm_vec3* v = malloc(n * sizeof *v);
  float* F = malloc(n * 9 * sizeof *F);
  expectError(mpm_scene_read_positions(scene, id, x, 1, &count), MPM_ERROR_BUFFER_TOO_SMALL, "capacity = 1");
  CHECK(count == n, "the count is written even when the buffer is too small (%zu)", count);
  CHECK(mpm_scene_read_positions(scene, id, x, n, &count) == MPM_OK, "%s", mpm_last_error());
  const double y0 = meanY(x, n);

  /* a kinematic box far below (it must not touch the block) and a needle and a blade
   * away from it: each reports a zero impulse */
  mpm_shape_desc ground;
  mpm_shape_desc_default(&ground);
  ground.geometry = MPM_GEOMETRY_BOX;
  ground.half_extents = (mpm_vec3){0.2f, 0.02f, 0.2f};
  ground.state.pose.position = (mpm_vec3){0.f, -0.2f, 0.f};
  ground.contact_mode = 3;
  mpm_shape_id groundId;
  expectError(mpm_scene_add_shape(scene, &ground, &groundId), MPM_ERROR_INVALID_ARGUMENT, "contact_mode = 3");
  ground.contact_mode = MPM_CONTACT_FRICTIONAL;
  CHECK(mpm_scene_add_shape(scene, &ground, &groundId) == MPM_OK, "%s", mpm_last_error());
  mpm_quad_slicer_desc blade;
  mpm_quad_slicer_desc_default(&blade);
  blade.state.pose.position = (mpm_vec3){0.2f, 0.2f, 0.f};
  mpm_slicer_id bladeId;
  CHECK(mpm_scene_add_quad_slicer(scene, &blade, &bladeId) == MPM_OK, "%s", mpm_last_error());
  mpm_arc_desc needle;
  mpm_arc_desc_default(&needle);
  needle.state.pose.position = (mpm_vec3){-0.2f, 0.2f, 0.f};
  needle.end_angle = 7.f;
  mpm_curve_id needleId;
  expectError(mpm_scene_add_arc(scene, &needle, &needleId), MPM_ERROR_INVALID_ARGUMENT, "endAngle = 7");
  mpm_arc_desc_default(&needle);
  needle.state.pose.position = (mpm_vec3){-0.2f, 0.2f, 0.f};
  CHECK(mpm_scene_add_arc(scene, &needle, &needleId) == MPM_OK, "%s", mpm_last_error());

  mpm_step_report report;
  CHECK(mpm_scene_step(scene, 0.1f, &report) == MPM_OK, "%s", mpm_last_error());
  double t = 0;
  CHECK(mpm_scene_time(scene, &t) == MPM_OK && fabs(t - 0.1) < 1e-6, "time %g", t);
  CHECK(mpm_scene_read_positions(scene, id, x, n, &count) == MPM_OK, "%s", mpm_last_error());
  CHECK(mpm_scene_read_velocities(scene, id, v, n, &count) == MPM_OK, "%s", mpm_last_error());
  CHECK(mpm_scene_read_deformation_gradients(scene, id, F, n, &count) == MPM_OK, "%s", mpm_last_error());
  /* symplectic Euler over N equal substeps: v_k = -g k dt, so the fall is
   * g dt^2 N (N + 1) / 2 = g t^2 / 2 (1 + 1 / N) */
  const double N = report.substeps, fall = 0.5 * 9.81 * t * t * (1 + 1 / N), fell = y0 - meanY(x, n);
  printf("free fall over %.2f s in %d substeps: %.6f m, closed form %.6f m\n", t, report.substeps, fell, fall);
  CHECK(fabs(fell - fall) < 1e-3 * fall, "the centre fell %.6f m, g t^2 (1 + 1/N) / 2 = %.6f m (1e-3 of it)", fell, fall);
  double worstV = 0, worstF = 0;
  for (size_t i = 0; i < n; ++i) {
    worstV = fmax(worstV, fabs(v[i].y + 9.81 * t) + fabs(v[i].x) + fabs(v[i].z));
    for (int k = 0; k < 9; ++k) worstF = fmax(worstF, fabs(F[9 * i + k] - (k % 4 == 0 ? 1.f : 0.f)));
  }
  printf("largest |v - (0, -g t, 0)| %.2e m/s, largest |F - I| %.2e\n", worstV, worstF);
  CHECK(worstV < 1e-3 * 9.81 * t, "velocities follow -g t (%.3e)", worstV);
  CHECK(worstF < 1e-4, "a falling block does not deform (%.3e)", worstF);

  mpm_impulse J;
  int inside = -1;
  CHECK(mpm_scene_shape_impulse(scene, groundId, &J) == MPM_OK && J.linear.y == 0.f, "the ground is not touched");
  CHECK(mpm_scene_slicer_impulse(scene, bladeId, &J) == MPM_OK && J.linear.x == 0.f, "the blade is not touched");
  CHECK(mpm_scene_curve_impulse(scene, needleId, &J) == MPM_OK && J.linear.x == 0.f, "the needle is not touched");
  CHECK(mpm_scene_tip_inside(scene, needleId, &inside) == MPM_OK && inside == 0, "the tip is outside");

  /* a shape's state goes in and comes back */
  mpm_body_state st = ground.state, back;
  st.pose.position.y = -0.21f;
  st.linear_velocity = (mpm_vec3){0.f, -0.1f, 0.f};
  CHECK(mpm_scene_set_shape_state(scene, groundId, &st) == MPM_OK, "%s", mpm_last_error());
  CHECK(mpm_scene_shape_state(scene, groundId, &back) == MPM_OK && back.pose.position.y == -0.21f &&
            back.linear_velocity.y == -0.1f,
        "state read back");
  CHECK(mpm_scene_set_slicer_state(scene, bladeId, &blade.state) == MPM_OK, "%s", mpm_last_error());
  CHECK(mpm_scene_set_curve_state(scene, needleId, &needle.state) == MPM_OK, "%s", mpm_last_error());
  expectError(mpm_scene_set_shape_state(scene, groundId, NULL), MPM_ERROR_INVALID_ARGUMENT, "state = NULL");

  /* --- checkpoint: saved, stepped on, loaded back and stepped again: bit for bit --- */
  const char* path = "test_c_api.ckpt";
  CHECK(mpm_scene_save(scene, path) == MPM_OK, "%s", mpm_last_error());
  CHECK(mpm_scene_advance(scene, 0.05f) == MPM_OK, "%s", mpm_last_error());
  CHECK(mpm_scene_fetch_results(scene, &report) == MPM_OK, "%s", mpm_last_error());
  mpm_vec3* first = malloc(n * sizeof *first);
  CHECK(mpm_scene_read_positions(scene, id, first, n, &count) == MPM_OK, "%s", mpm_last_error());
  CHECK(mpm_scene_load(scene, path) == MPM_OK, "%s", mpm_last_error());
  CHECK(mpm_scene_step(scene, 0.05f, NULL) == MPM_OK, "%s", mpm_last_error());
  CHECK(mpm_scene_read_positions(scene, id, x, n, &count) == MPM_OK, "%s", mpm_last_error());
  CHECK(memcmp(first, x, n * sizeof *x) == 0, "the run from the checkpoint is the run that was saved");
  remove(path);
  expectError(mpm_scene_load(scene, "no/such/file.ckpt"), MPM_ERROR_CHECKPOINT, "no/such/file.ckpt");

  /* --- stale handles, and the scene still steps after every refusal --- */
  CHECK(mpm_scene_remove_shape(scene, groundId) == MPM_OK, "%s", mpm_last_error());
  expectError(mpm_scene_shape_impulse(scene, groundId, &J), MPM_ERROR_INVALID_ARGUMENT, "ShapeId");
  CHECK(mpm_scene_remove_slicer(scene, bladeId) == MPM_OK, "%s", mpm_last_error());
  CHECK(mpm_scene_remove_curve(scene, needleId) == MPM_OK, "%s", mpm_last_error());
  CHECK(mpm_scene_remove_object(scene, id) == MPM_OK, "%s", mpm_last_error());
  expectError(mpm_scene_particle_count(scene, id, &count), MPM_ERROR_INVALID_ARGUMENT, "ParticleObjectId");
  expectError(mpm_scene_step(NULL, 0.01f, NULL), MPM_ERROR_INVALID_ARGUMENT, "scene = NULL");
  CHECK(mpm_scene_step(scene, 0.01f, NULL) == MPM_OK, "%s", mpm_last_error());

  mpm_scene_release(scene);
  mpm_scene_release(NULL);
  free(x);
  free(v);
  free(F);
  free(first);
  printf(failures ? "test_c_api: %d FAILED\n" : "test_c_api: all passed\n", failures);
  return failures ? 1 : 0;
}
