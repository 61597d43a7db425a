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

/* A call that must fail with `status` and a message containing `needle`, in the C
 * header's names: no C++ struct's name (SceneSettings.dx is mpm_scene_settings.dx here). */
static void expectError(mpm_status got, mpm_status status, const char* needle) {
  static const char* const cxxNames[] = {"SceneSettings.", "ParticleObjectDesc.", "ShapeDesc.",       "ShapeState.",
                                         "QuadSlicerDesc.", "MeshSlicerDesc.",    "ArcDesc.",         "LineSegmentsDesc.",
                                         "cellSize"};
  CHECK(got == status, "status %d, expected %d (%s)", (int)got, (int)status, mpm_last_error());
  CHECK(strstr(mpm_last_error(), needle) != NULL, "message \"%s\" does not name \"%s\"", mpm_last_error(), needle);
  for (size_t i = 0; i < sizeof cxxNames / sizeof cxxNames[0]; ++i)
    CHECK(strstr(mpm_last_error(), cxxNames[i]) == NULL, "message \"%s\" names the C++ %s", mpm_last_error(),
          cxxNames[i]);
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

/* A closed box mesh of half sizes h about the origin: 8 corners, 12 triangles wound
 * counter-clockwise seen from outside. */
static const uint32_t kBoxIndices[36] = {0, 2, 1, 0, 3, 2, 4, 5, 6, 4, 6, 7, 0, 1, 5, 0, 5, 4,
                                         3, 7, 6, 3, 6, 2, 0, 4, 7, 0, 7, 3, 1, 2, 6, 1, 6, 5};
static mpm_triangle_mesh boxMesh(mpm_vec3 h, mpm_vec3 corners[8]) {
  for (int i = 0; i < 8; ++i) {
    corners[i].x = (i == 1 || i == 2 || i == 5 || i == 6) ? h.x : -h.x;
    corners[i].y = (i == 2 || i == 3 || i == 6 || i == 7) ? h.y : -h.y;
    corners[i].z = i >= 4 ? h.z : -h.z;
  }
  mpm_triangle_mesh m = {corners, 8, kBoxIndices, 12};
  return m;
}

/* Momentum of an object's particles along x (axis 0) or y (1) [kg m/s], each of mass `mass`. */
static double momentum(const mpm_scene* scene, mpm_object_id id, mpm_vec3* v, size_t n, double mass, int axis) {
  size_t count = 0;
  CHECK(mpm_scene_read_velocities(scene, id, v, n, &count) == MPM_OK && count == n, "%s", mpm_last_error());
  double p = 0;
  for (size_t i = 0; i < n; ++i) p += mass * (axis == 0 ? v[i].x : v[i].y);
  return p;
}

/* Two tissue blocks come to rest, one on a compound shape (a box part and a mesh part side
 * by side, the block across both), one, itself filled from a closed box mesh, on a one-part
 * mesh shape built from triangles. Over the last 0.4 s of 1.2 each shape's vertical impulse
 * J balances the block's weight and momentum change exactly (J + m g T + dp = 0 to 1e-5 of
 * m g T, measured 2e-7: the grid passes momentum between them and nothing else touches the
 * block), and once settled the block's weight alone (J = -m g T to 1 %, measured 0.4 %: the
 * block's leftover oscillation, its dp). Then a thread dragged sideways through the meshed block
 * is held back (each segment's impulse against its motion) and a mesh blade pushed down
 * into the other block is pushed up. The new calls' error paths are named on the way. */
static void restingOnCompoundAndMeshShapes(void) {
  printf("--- compound and mesh shapes, mesh tissue, a mesh blade, a thread ---\n");
  mpm_scene_settings s = settings();
  mpm_scene* scene = NULL;
  CHECK(mpm_scene_create(&s, &scene) == MPM_OK, "%s", mpm_last_error());
  if (!scene) return;
  const double g = 9.81, density = 1000, h = 0.5 * s.dx; /* particles per cell axis 2 */
  mpm_vec3 floorCorners[8], halfCorners[8], cubeCorners[8];
  const mpm_vec3 floorHalf = {0.08f, 0.02f, 0.08f}, halfHalf = {0.04f, 0.02f, 0.08f}, cubeHalf = {0.05f, 0.05f, 0.05f};
  mpm_triangle_mesh floorMesh = boxMesh(floorHalf, floorCorners), halfMesh = boxMesh(halfHalf, halfCorners),
                    cubeMesh = boxMesh(cubeHalf, cubeCorners);

  /* the compound floor at x = -0.15: a box part and a mesh part, each 8 cm by 16 cm */
  mpm_shape_desc body;
  mpm_shape_desc_default(&body);
  body.state.pose.position = (mpm_vec3){-0.15f, -0.05f, 0.f};
  mpm_shape_part parts[2];
  mpm_shape_part_default(&parts[0]);
  mpm_shape_part_default(&parts[1]);
  parts[0].geometry = MPM_GEOMETRY_BOX;
  parts[0].half_extents = halfHalf;
  parts[0].local_pose.position = (mpm_vec3){-0.04f, 0.f, 0.f};
  parts[1].geometry = MPM_GEOMETRY_MESH;
  parts[1].mesh = halfMesh;
  parts[1].local_pose.position = (mpm_vec3){0.04f, 0.f, 0.f};
  mpm_shape_id compound, meshFloor;
  expectError(mpm_scene_add_compound_shape(scene, &body, parts, 0, &compound), MPM_ERROR_INVALID_ARGUMENT,
              "part_count = 0");
  expectError(mpm_scene_add_compound_shape(scene, &body, NULL, 2, &compound), MPM_ERROR_INVALID_ARGUMENT,
              "parts = NULL");
  parts[1].geometry = 6;
  expectError(mpm_scene_add_compound_shape(scene, &body, parts, 2, &compound), MPM_ERROR_INVALID_ARGUMENT,
              "parts[1].geometry = 6");
  parts[1].geometry = MPM_GEOMETRY_MESH;
  parts[1].mesh_cell_size = -1.f;
  expectError(mpm_scene_add_compound_shape(scene, &body, parts, 2, &compound), MPM_ERROR_INVALID_ARGUMENT,
              "parts[1].mesh_cell_size = -1");
  parts[1].mesh_cell_size = 0.f;
  parts[0].half_extents.y = -1.f;
  expectError(mpm_scene_add_compound_shape(scene, &body, parts, 2, &compound), MPM_ERROR_INVALID_ARGUMENT,
              "parts[0].half_extents = (");
  parts[0].half_extents = halfHalf;
  uint32_t badIndices[36];
  memcpy(badIndices, kBoxIndices, sizeof badIndices);
  badIndices[5] = 8;
  parts[1].mesh.indices = badIndices;
  expectError(mpm_scene_add_compound_shape(scene, &body, parts, 2, &compound), MPM_ERROR_INVALID_ARGUMENT,
              "parts[1].mesh.indices[5] = 8");
  parts[1].mesh.indices = NULL;
  expectError(mpm_scene_add_compound_shape(scene, &body, parts, 2, &compound), MPM_ERROR_INVALID_ARGUMENT,
              "parts[1].mesh.indices = NULL");
  parts[1].mesh = halfMesh;
  CHECK(mpm_scene_add_compound_shape(scene, &body, parts, 2, &compound) == MPM_OK, "%s", mpm_last_error());

  /* the mesh floor at x = +0.15, one part through mpm_scene_add_shape */
  mpm_shape_desc floorDesc;
  mpm_shape_desc_default(&floorDesc);
  floorDesc.geometry = MPM_GEOMETRY_MESH;
  floorDesc.state.pose.position = (mpm_vec3){0.15f, -0.05f, 0.f};
  floorDesc.mesh = floorMesh;
  floorDesc.mesh.vertices = NULL;
  expectError(mpm_scene_add_shape(scene, &floorDesc, &meshFloor), MPM_ERROR_INVALID_ARGUMENT,
              "mpm_shape_desc.mesh.vertices = NULL");
  floorDesc.mesh = floorMesh;
  floorDesc.mesh.triangle_count = 0;
  expectError(mpm_scene_add_shape(scene, &floorDesc, &meshFloor), MPM_ERROR_INVALID_ARGUMENT,
              "mpm_shape_desc.mesh.indices = 0 indices");
  floorDesc.mesh = floorMesh;
  CHECK(mpm_scene_add_shape(scene, &floorDesc, &meshFloor) == MPM_OK, "%s", mpm_last_error());

  /* the blocks: 10 cm cubes of 50 kPa tissue, 5 mm above their floors' tops (y = -0.03) */
  mpm_object_desc block;
  mpm_object_desc_default(&block);
  block.material.youngs_modulus = 5e4f;
  block.material.density = (float)density;
  block.half_extents = cubeHalf;
  block.center = (mpm_vec3){-0.15f, 0.02f, 0.f};
  mpm_object_id onCompound, onMesh;
  CHECK(mpm_scene_add_object(scene, &block, &onCompound) == MPM_OK, "%s", mpm_last_error());
  block.center = (mpm_vec3){0.15f, 0.02f, 0.f};
  block.primitive = 4;
  expectError(mpm_scene_add_object(scene, &block, &onMesh), MPM_ERROR_INVALID_ARGUMENT, "mpm_object_desc.primitive = 4");
  block.primitive = MPM_PRIMITIVE_MESH;
  block.mesh = cubeMesh;
  block.mesh.triangle_count = 11; /* a hole: no inside */
  expectError(mpm_scene_add_object(scene, &block, &onMesh), MPM_ERROR_INVALID_ARGUMENT, "mpm_object_desc.mesh");
  block.mesh = cubeMesh;
  CHECK(mpm_scene_add_object(scene, &block, &onMesh) == MPM_OK, "%s", mpm_last_error());
  size_t n = 0, nMesh = 0;
  CHECK(mpm_scene_particle_count(scene, onCompound, &n) == MPM_OK && n == 1000, "particles %zu", n);
  CHECK(mpm_scene_particle_count(scene, onMesh, &nMesh) == MPM_OK && nMesh == n,
        "the box mesh holds the box's %zu particles (%zu)", n, nMesh);
  if (n != 1000 || nMesh != n) {
    mpm_scene_release(scene);
    return;
  }
  const double m = density * h * h * h, weight = n * m * g; /* per particle [kg]; [N] */
  mpm_vec3* v = malloc(n * sizeof *v);

  const float frame = 0.02f;
  const int frames = 60, window = 20;
  double J[2] = {0, 0}, p0[2] = {0, 0};
  const mpm_shape_id floors[2] = {compound, meshFloor};
  const mpm_object_id blocks[2] = {onCompound, onMesh};
  for (int f = 0; f < frames; ++f) {
    if (f == frames - window)
      for (int k = 0; k < 2; ++k) p0[k] = momentum(scene, blocks[k], v, n, m, 1);
    CHECK(mpm_scene_step(scene, frame, NULL) == MPM_OK, "%s", mpm_last_error());
    if (f >= frames - window)
      for (int k = 0; k < 2; ++k) {
        mpm_impulse j;
        CHECK(mpm_scene_shape_impulse(scene, floors[k], &j) == MPM_OK, "%s", mpm_last_error());
        J[k] += j.linear.y;
      }
  }
  const double T = window * frame;
  for (int k = 0; k < 2; ++k) {
    const double dp = momentum(scene, blocks[k], v, n, m, 1) - p0[k];
    printf("%s: J_y %.6f N s over %.2f s, -m g T %.6f N s, block dp %.6f N s: balance %.2e, rest %.4f of the weight\n",
           k ? "mesh floor, mesh block" : "compound floor", J[k], T, -weight * T, dp, J[k] + weight * T + dp,
           -J[k] / (weight * T));
    CHECK(fabs(J[k] + weight * T + dp) < 1e-5 * weight * T, "J + m g T + dp = %.3e (1e-5 of m g T)",
          J[k] + weight * T + dp);
    CHECK(fabs(-J[k] / (weight * T) - 1) < 0.01, "resting: -J / (m g T) = %.4f (1%%)", -J[k] / (weight * T));
  }

  /* a thread of three points along z through the meshed block, dragged along +x */
  mpm_line_segments_desc thread;
  mpm_line_segments_desc_default(&thread);
  mpm_vec3 pts[3] = {{0.13f, 0.02f, -0.03f}, {0.13f, 0.02f, 0.f}, {0.13f, 0.02f, 0.03f}};
  mpm_vec3 vel[3] = {{0.2f, 0.f, 0.f}, {0.2f, 0.f, 0.f}, {0.2f, 0.f, 0.f}};
  mpm_curve_id threadId;
  thread.points = pts;
  thread.point_count = 1;
  expectError(mpm_scene_add_line_segments(scene, &thread, &threadId), MPM_ERROR_INVALID_ARGUMENT,
              "mpm_line_segments_desc.points = 1 points");
  thread.points = NULL;
  thread.point_count = 3;
  expectError(mpm_scene_add_line_segments(scene, &thread, &threadId), MPM_ERROR_INVALID_ARGUMENT,
              "mpm_line_segments_desc.points = NULL");
  thread.points = pts;
  thread.velocities = vel;
  CHECK(mpm_scene_add_line_segments(scene, &thread, &threadId) == MPM_OK, "%s", mpm_last_error());
  expectError(mpm_scene_set_curve_points(scene, threadId, pts, NULL, 2), MPM_ERROR_INVALID_ARGUMENT,
              "points");
  mpm_impulse segments[2], total;
  size_t count = 0;
  const float dt = 0.01f;
  const double px0 = momentum(scene, onMesh, v, n, m, 0);
  double taken = 0, floorX = 0; /* the thread's and the floor's x impulses over the drag */
  for (int f = 0; f < 5; ++f) {
    CHECK(mpm_scene_step(scene, dt, NULL) == MPM_OK, "%s", mpm_last_error());
    for (int i = 0; i < 3; ++i) pts[i].x += vel[i].x * dt;
    CHECK(mpm_scene_set_curve_points(scene, threadId, pts, vel, 3) == MPM_OK, "%s", mpm_last_error());
    if (f == 0)
      expectError(mpm_scene_segment_impulses(scene, threadId, segments, 1, &count), MPM_ERROR_BUFFER_TOO_SMALL,
                  "capacity = 1");
    CHECK(mpm_scene_segment_impulses(scene, threadId, segments, 2, &count) == MPM_OK && count == 2, "%s (%zu)",
          mpm_last_error(), count);
    CHECK(mpm_scene_curve_impulse(scene, threadId, &total) == MPM_OK, "%s", mpm_last_error());
    printf("thread dragged along +x at 0.2 m/s, %.2f s: segment impulses x %.3e, %.3e N s (the curve's %.3e)\n",
           (f + 1) * dt, segments[0].linear.x, segments[1].linear.x, total.linear.x);
    if (f == 0) /* later the block, dragged along on its frictionless floor, catches up */
      CHECK(segments[0].linear.x < 0.f && segments[1].linear.x < 0.f, "the tissue holds each segment back");
    CHECK(fabs(segments[0].linear.x + segments[1].linear.x - total.linear.x) <= 1e-6 * fabs(total.linear.x),
          "the segments' impulses sum to the curve's");
    taken += total.linear.x;
    mpm_impulse j;
    CHECK(mpm_scene_shape_impulse(scene, meshFloor, &j) == MPM_OK, "%s", mpm_last_error());
    floorX += j.linear.x;
  }
  /* the thread pushes the block along x, and the frictionless floor a little where the
   * block tilts (no wall is near): their impulses are the block's momentum gain */
  const double px = momentum(scene, onMesh, v, n, m, 0) - px0;
  printf("the block's x momentum gained %.6f N s, the thread's impulse %.6f N s, the floor's %.2e: balance %.2e\n",
         px, taken, floorX, px + taken + floorX);
  CHECK(px > 0 && fabs(px + taken + floorX) < 1e-4 * px, "the thread's and floor's impulses are the block's momentum "
        "gain (1e-4 of it)");
  CHECK(mpm_scene_remove_curve(scene, threadId) == MPM_OK, "%s", mpm_last_error());
  expectError(mpm_scene_set_curve_points(scene, threadId, pts, vel, 3), MPM_ERROR_INVALID_ARGUMENT, "CurveId");

  /* a mesh blade (a 6 cm by 2 cm quad as two triangles, edge along x at y = 0, a spine of
   * 3 mm along its back at y = 2 cm) pushed down into the block on the compound floor: its
   * edge cuts at no cost (no toughness: the faces move along themselves), its blunt spine
   * is pushed back up */
  mpm_vec3 bladeCorners[4] = {{-0.03f, 0.f, 0.f}, {0.03f, 0.f, 0.f}, {0.03f, 0.02f, 0.f}, {-0.03f, 0.02f, 0.f}};
  uint32_t bladeIndices[6] = {0, 1, 2, 0, 2, 3};
  mpm_mesh_slicer_desc blade;
  mpm_mesh_slicer_desc_default(&blade);
  blade.blade = (mpm_triangle_mesh){bladeCorners, 4, bladeIndices, 2};
  blade.spine_from = (mpm_vec3){-0.03f, 0.02f, 0.f};
  blade.spine_to = (mpm_vec3){0.03f, 0.02f, 0.f};
  blade.spine_radius = 0.003f;
  blade.state.pose.position = (mpm_vec3){-0.15f, 0.055f, 0.f}; /* the spine 5 mm above the block */
  blade.state.linear_velocity = (mpm_vec3){0.f, -0.5f, 0.f};
  mpm_slicer_id bladeId;
  bladeIndices[3] = 2, bladeIndices[4] = 0; /* the second triangle wound the other way */
  expectError(mpm_scene_add_mesh_slicer(scene, &blade, &bladeId), MPM_ERROR_INVALID_ARGUMENT,
              "mpm_mesh_slicer_desc.blade");
  bladeIndices[3] = 0, bladeIndices[4] = 2;
  blade.blade.vertices = NULL;
  expectError(mpm_scene_add_mesh_slicer(scene, &blade, &bladeId), MPM_ERROR_INVALID_ARGUMENT,
              "mpm_mesh_slicer_desc.blade.vertices = NULL");
  blade.blade.vertices = bladeCorners;
  CHECK(mpm_scene_add_mesh_slicer(scene, &blade, &bladeId) == MPM_OK, "%s", mpm_last_error());
  mpm_impulse bladeJ;
  double pushed = 0;
  for (int f = 0; f < 4; ++f) { /* down 2 cm: the spine 1.5 cm into the block */
    CHECK(mpm_scene_step(scene, 0.01f, NULL) == MPM_OK, "%s", mpm_last_error());
    blade.state.pose.position.y -= 0.005f;
    CHECK(mpm_scene_set_slicer_state(scene, bladeId, &blade.state) == MPM_OK, "%s", mpm_last_error());
    CHECK(mpm_scene_slicer_impulse(scene, bladeId, &bladeJ) == MPM_OK, "%s", mpm_last_error());
    pushed += bladeJ.linear.y;
  }
  printf("mesh blade pushed down at 0.5 m/s, its spine 1.5 cm into the block: impulse y %.3e N s\n", pushed);
  CHECK(pushed > 0, "the tissue pushes the blade back up (%.3e)", pushed);
  CHECK(mpm_scene_remove_slicer(scene, bladeId) == MPM_OK, "%s", mpm_last_error());
  CHECK(mpm_scene_remove_shape(scene, compound) == MPM_OK, "%s", mpm_last_error());
  CHECK(mpm_scene_step(scene, 0.01f, NULL) == MPM_OK, "%s", mpm_last_error());
  mpm_scene_release(scene);
  free(v);
}

/* A batch of three scenes (blocks started at different speeds) stepped together on two
 * threads ends bit for bit where each scene stepped alone does; a NULL or repeated scene,
 * a NULL batch and a bad dt are refused by name. */
static void batchOfScenes(void) {
  printf("--- a batch of scenes ---\n");
  enum { kScenes = 3, kSteps = 6 };
  mpm_scene_settings s = settings();
  mpm_scene *together[kScenes], *alone[kScenes];
  mpm_object_id ids[kScenes], aloneIds[kScenes];
  for (int i = 0; i < kScenes; ++i) {
    mpm_object_desc block;
    mpm_object_desc_default(&block);
    block.half_extents = (mpm_vec3){0.04f, 0.04f, 0.04f};
    block.velocity = (mpm_vec3){0.f, -0.5f * (float)i, 0.f};
    together[i] = alone[i] = NULL;
    CHECK(mpm_scene_create(&s, &together[i]) == MPM_OK && mpm_scene_create(&s, &alone[i]) == MPM_OK, "%s",
          mpm_last_error());
    if (!together[i] || !alone[i]) return;
    CHECK(mpm_scene_add_object(together[i], &block, &ids[i]) == MPM_OK, "%s", mpm_last_error());
    CHECK(mpm_scene_add_object(alone[i], &block, &aloneIds[i]) == MPM_OK, "%s", mpm_last_error());
  }
  mpm_batch* batch = NULL;
  mpm_scene* withNull[2] = {together[0], NULL};
  expectError(mpm_batch_create(withNull, 2, 2, &batch), MPM_ERROR_INVALID_ARGUMENT, "scenes[1] = null");
  mpm_scene* twice[2] = {together[0], together[0]};
  expectError(mpm_batch_create(twice, 2, 2, &batch), MPM_ERROR_INVALID_ARGUMENT, "scenes[1] = scenes[0]");
  expectError(mpm_batch_create(together, kScenes, -2, &batch), MPM_ERROR_INVALID_ARGUMENT, "threads = -2");
  CHECK(batch == NULL, "no batch on failure");
  expectError(mpm_batch_step(NULL, 0.01f, NULL), MPM_ERROR_INVALID_ARGUMENT, "batch = NULL");
  CHECK(mpm_batch_create(together, kScenes, 2, &batch) == MPM_OK, "%s", mpm_last_error());
  if (!batch) return;
  expectError(mpm_batch_step(batch, -0.01f, NULL), MPM_ERROR_INVALID_ARGUMENT, "dt = -0.01");
  mpm_step_report reports[kScenes];
  for (int k = 0; k < kSteps; ++k) {
    CHECK(mpm_batch_step(batch, 1.f / 240, reports) == MPM_OK, "%s", mpm_last_error());
    for (int i = 0; i < kScenes; ++i) CHECK(mpm_scene_step(alone[i], 1.f / 240, NULL) == MPM_OK, "%s", mpm_last_error());
  }
  CHECK(reports[2].substeps >= 1, "substeps %d", reports[2].substeps);
  mpm_batch_release(batch);
  mpm_batch_release(NULL);
  size_t n = 0;
  CHECK(mpm_scene_particle_count(alone[0], aloneIds[0], &n) == MPM_OK && n > 0, "%s", mpm_last_error());
  mpm_vec3 *a = malloc(n * sizeof *a), *b = malloc(n * sizeof *b);
  double y[kScenes];
  for (int i = 0; i < kScenes; ++i) {
    size_t ca = 0, cb = 0;
    CHECK(mpm_scene_read_positions(together[i], ids[i], a, n, &ca) == MPM_OK &&
              mpm_scene_read_positions(alone[i], aloneIds[i], b, n, &cb) == MPM_OK && ca == n && cb == n,
          "%s", mpm_last_error());
    CHECK(memcmp(a, b, n * sizeof *a) == 0, "scene %d in the batch ends where it does alone", i);
    y[i] = meanY(a, n);
    mpm_scene_release(together[i]);
    mpm_scene_release(alone[i]);
  }
  CHECK(y[2] < y[1] && y[1] < y[0], "the faster blocks fell further: %.5f %.5f %.5f", y[0], y[1], y[2]);
  free(a);
  free(b);
}

/* While an advance runs every call on the scene returns MPM_ERROR_BUSY, naming the call;
 * mpm_scene_cancel stops it: the fetch returns MPM_ERROR_CANCELLED and the scene is as
 * before the advance (its time 0, its particles where they were). */
static void busyAndCancelled(void) {
  printf("--- busy during an advance, and cancelled ---\n");
  mpm_scene_settings s = settings();
  mpm_scene* scene = NULL;
  CHECK(mpm_scene_create(&s, &scene) == MPM_OK, "%s", mpm_last_error());
  if (!scene) return;
  mpm_object_desc block;
  mpm_object_desc_default(&block);
  block.half_extents = (mpm_vec3){0.05f, 0.05f, 0.05f};
  mpm_object_id id;
  CHECK(mpm_scene_add_object(scene, &block, &id) == MPM_OK, "%s", mpm_last_error());
  size_t n = 0, count = 0;
  CHECK(mpm_scene_particle_count(scene, id, &n) == MPM_OK && n > 0, "%s", mpm_last_error());
  mpm_vec3 *before = malloc(n * sizeof *before), *after = malloc(n * sizeof *after);
  CHECK(mpm_scene_read_positions(scene, id, before, n, &count) == MPM_OK, "%s", mpm_last_error());
  CHECK(mpm_scene_advance(scene, 1000.f) == MPM_OK, "%s", mpm_last_error()); /* minutes of substeps */
  expectError(mpm_scene_read_positions(scene, id, after, n, &count), MPM_ERROR_BUSY, "a step is running");
  double t = -1;
  expectError(mpm_scene_time(scene, &t), MPM_ERROR_BUSY, "time");
  CHECK(mpm_scene_cancel(scene) == MPM_OK, "%s", mpm_last_error());
  expectError(mpm_scene_fetch_results(scene, NULL), MPM_ERROR_CANCELLED, "cancelled");
  CHECK(mpm_scene_time(scene, &t) == MPM_OK && t == 0.0, "time %g after the cancelled advance", t);
  CHECK(mpm_scene_read_positions(scene, id, after, n, &count) == MPM_OK, "%s", mpm_last_error());
  CHECK(memcmp(before, after, n * sizeof *before) == 0, "the particles are where they were");
  CHECK(mpm_scene_step(scene, 0.01f, NULL) == MPM_OK, "%s", mpm_last_error());
  expectError(mpm_scene_cancel(NULL), MPM_ERROR_INVALID_ARGUMENT, "scene = NULL");
  free(before);
  free(after);
  mpm_scene_release(scene);
}

int main(void) {
  /* --- errors before a scene exists: each names its field and value --- */
  mpm_scene* scene = NULL;
  mpm_scene_settings s = settings();
  s.dx = 0.f;
  expectError(mpm_scene_create(&s, &scene), MPM_ERROR_INVALID_ARGUMENT, "mpm_scene_settings.dx = 0");
  CHECK(scene == NULL, "no scene on failure");
  s = settings();
  s.solver = 7;
  expectError(mpm_scene_create(&s, &scene), MPM_ERROR_INVALID_ARGUMENT, "mpm_scene_settings.solver = 7");
  s.solver = MPM_SOLVER_MLS;
  s.backend = -1;
  expectError(mpm_scene_create(&s, &scene), MPM_ERROR_INVALID_ARGUMENT, "mpm_scene_settings.backend = -1");
  expectError(mpm_scene_create(NULL, &scene), MPM_ERROR_INVALID_ARGUMENT, "settings = NULL");
  s = settings();
  s.domain_upper.y = s.domain_lower.y - 1.f;
  expectError(mpm_scene_create(&s, &scene), MPM_ERROR_INVALID_ARGUMENT, "mpm_scene_settings.domain_upper = (");
  s = settings();
  s.pb_iterations = 0;
  s.solver = MPM_SOLVER_PB;
  expectError(mpm_scene_create(&s, &scene), MPM_ERROR_INVALID_ARGUMENT, "mpm_scene_settings.pb_iterations = 0");

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
  expectError(mpm_scene_add_object(scene, &block, &id), MPM_ERROR_INVALID_ARGUMENT,
              "mpm_object_desc.material.poisson_ratio = 0.7");
  block.material.poisson_ratio = 0.3f;
  block.material.model = 5;
  expectError(mpm_scene_add_object(scene, &block, &id), MPM_ERROR_INVALID_ARGUMENT, "material.model = 5");
  block.material.model = MPM_NEO_HOOKEAN_DECOUPLED;
  /* not-a-number values as such, whatever NAN's sign bit */
  block.material.youngs_modulus = -NAN;
  expectError(mpm_scene_add_object(scene, &block, &id), MPM_ERROR_INVALID_ARGUMENT, "youngs_modulus = nan:");
  block.material.youngs_modulus = -INFINITY;
  expectError(mpm_scene_add_object(scene, &block, &id), MPM_ERROR_INVALID_ARGUMENT, "youngs_modulus = -inf:");
  block.material.youngs_modulus = 2e4f;
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
  ground.half_extents.x = -0.2f;
  expectError(mpm_scene_add_shape(scene, &ground, &groundId), MPM_ERROR_INVALID_ARGUMENT,
              "mpm_shape_desc.half_extents = (-0.2, 0.02, 0.2)");
  ground.half_extents.x = 0.2f;
  ground.state.linear_velocity.x = 1e30f;
  expectError(mpm_scene_add_shape(scene, &ground, &groundId), MPM_ERROR_INVALID_ARGUMENT,
              "mpm_shape_desc.state.linear_velocity = (1e+30, 0, 0)");
  ground.state.linear_velocity.x = 0.f;
  CHECK(mpm_scene_add_shape(scene, &ground, &groundId) == MPM_OK, "%s", mpm_last_error());
  mpm_body_state fast = ground.state;
  fast.angular_velocity.z = 1e30f;
  expectError(mpm_scene_set_shape_state(scene, groundId, &fast), MPM_ERROR_INVALID_ARGUMENT,
              "mpm_body_state.angular_velocity = (0, 0, 1e+30)");
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
  expectError(mpm_scene_add_arc(scene, &needle, &needleId), MPM_ERROR_INVALID_ARGUMENT, "mpm_arc_desc.end_angle = 7");
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

  restingOnCompoundAndMeshShapes();
  batchOfScenes();
  busyAndCancelled();
  printf(failures ? "test_c_api: %d FAILED\n" : "test_c_api: all passed\n", failures);
  return failures ? 1 : 0;
}
