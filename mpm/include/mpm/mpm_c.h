/* C API of the MPM solver (C99), for engines and languages that only speak C (a game
 * engine's native plug-in, ctypes, FFI). It wraps mpm::Scene (mpm/scene.h): the same
 * scene, objects, shapes, slicers and curves, the same validation and the same errors.
 *
 * - Handles: a scene is an opaque pointer; objects, shapes, slicers and curves are small
 *   value handles (index and generation) that stay valid or are detectably stale.
 * - Errors: every call returns an mpm_status. On anything but MPM_OK nothing changed
 *   (the scene stays usable) and mpm_last_error() gives a message naming the field and
 *   the value, e.g. "mpm_scene_settings.solver = 7: must be one of MPM_SOLVER_...".
 *   The message is per thread and kept until this thread's next failed call.
 * - No C++ exception crosses this API; every enum value passed in is checked.
 * - Descriptions: fill one with its *_default() function, then set what differs, so a
 *   field added later keeps the library's default.
 * - Arrays: reads go into caller-provided buffers of `capacity` elements; the count is
 *   always written, and a buffer too small gives MPM_ERROR_BUFFER_TOO_SMALL.
 *
 * Units are SI (m, s, kg, Pa); vectors are in the world frame unless said otherwise.
 */
#ifndef MPM_MPM_C_H
#define MPM_MPM_C_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

typedef enum mpm_status {
  MPM_OK = 0,
  MPM_ERROR_INVALID_ARGUMENT = 1,   /* a field, value, pointer or handle (stale too) refused */
  MPM_ERROR_BUFFER_TOO_SMALL = 2,   /* the count was written; nothing else */
  MPM_ERROR_SIMULATION_DIVERGED = 3,/* the step was undone; the scene is as before it */
  MPM_ERROR_BACKEND_UNAVAILABLE = 4,/* e.g. MPM_BACKEND_CUDA without a device */
  MPM_ERROR_CHECKPOINT = 5,         /* the file could not be written or read, or was refused */
  MPM_ERROR_OUT_OF_MEMORY = 6,      /* the message names what and how many bytes; the scene is as before the call */
  MPM_ERROR_INTERNAL = 7,           /* anything else (a bug: please report the message) */
  MPM_ERROR_BUSY = 8,               /* an advance is running (on any thread): nothing read or changed; call
                                       again after mpm_scene_fetch_results */
  MPM_ERROR_CANCELLED = 9           /* mpm_scene_cancel stopped the advance; the scene is as before it */
} mpm_status;

/* The message of this thread's last failed call ("" if none). Valid until the next call
 * on this thread that fails. */
const char* mpm_last_error(void);

typedef enum mpm_solver { MPM_SOLVER_MLS = 0, MPM_SOLVER_STANDARD = 1, MPM_SOLVER_PB = 2, MPM_SOLVER_MTLED = 3 } mpm_solver;
typedef enum mpm_backend { MPM_BACKEND_AUTO = 0, MPM_BACKEND_CPU = 1, MPM_BACKEND_CUDA = 2 } mpm_backend;
typedef enum mpm_material_model { MPM_FIXED_COROTATED = 0, MPM_NEO_HOOKEAN_DECOUPLED = 1 } mpm_material_model;
typedef enum mpm_primitive {
  MPM_PRIMITIVE_BOX = 0, MPM_PRIMITIVE_SPHERE = 1, MPM_PRIMITIVE_CYLINDER = 2, MPM_PRIMITIVE_MESH = 3
} mpm_primitive;
typedef enum mpm_geometry {
  MPM_GEOMETRY_PLANE = 0, MPM_GEOMETRY_BOX = 1, MPM_GEOMETRY_SPHERE = 2, MPM_GEOMETRY_CAPSULE = 3,
  MPM_GEOMETRY_CYLINDER = 4, MPM_GEOMETRY_MESH = 5
} mpm_geometry;
typedef enum mpm_contact_mode { MPM_CONTACT_FRICTIONAL = 0, MPM_CONTACT_STICKY = 1, MPM_CONTACT_BONDED = 2 } mpm_contact_mode;

typedef struct mpm_vec3 { float x, y, z; } mpm_vec3;
typedef struct mpm_quat { float w, x, y, z; } mpm_quat;
typedef struct mpm_pose { mpm_vec3 position; mpm_quat rotation; } mpm_pose;
/* A body's pose and velocities: of its centre of mass (shapes) or frame origin (slicers,
 * needles); the angular velocity in the world frame. */
typedef struct mpm_body_state { mpm_pose pose; mpm_vec3 linear_velocity, angular_velocity; } mpm_body_state;
/* Momentum the grid gave a body over the last advance [kg m/s], [kg m^2/s]. */
typedef struct mpm_impulse { mpm_vec3 linear, angular; } mpm_impulse;

/* A triangle mesh the caller owns (copied by the call it is passed to): vertex_count
 * vertices [m] and triangle_count triangles, three indices each into the vertices, wound
 * counter-clockwise seen from outside. The library samples its signed distance on a grid
 * of `mesh_cell_size` (next to each mesh field; 0: half the scene's dx). */
typedef struct mpm_triangle_mesh {
  const mpm_vec3* vertices;
  size_t vertex_count;
  const uint32_t* indices;  /* 3 * triangle_count */
  size_t triangle_count;
} mpm_triangle_mesh;

typedef struct mpm_object_id { uint32_t index, generation; } mpm_object_id;
typedef struct mpm_shape_id { uint32_t index, generation; } mpm_shape_id;
typedef struct mpm_slicer_id { uint32_t index, generation; } mpm_slicer_id;
typedef struct mpm_curve_id { uint32_t index, generation; } mpm_curve_id;

typedef struct mpm_scene mpm_scene;

/* --- scene --- */
typedef struct mpm_scene_settings {
  mpm_vec3 domain_lower, domain_upper; /* the grid's box [m] */
  float dx;                            /* grid cell size [m] */
  mpm_vec3 gravity;                    /* [m/s^2] */
  int solver;                          /* mpm_solver */
  int backend;                         /* mpm_backend */
  int cpu_threads;                     /* 0: all hardware threads */
  int pb_iterations;                   /* MPM_SOLVER_PB: iterations per substep */
  float cfl_number;                    /* substep = cfl_number dx / the fastest wave; 0: the solver's default */
} mpm_scene_settings;
void mpm_scene_settings_default(mpm_scene_settings* settings);
mpm_status mpm_scene_create(const mpm_scene_settings* settings, mpm_scene** scene);
void mpm_scene_release(mpm_scene* scene); /* NULL is ignored */

/* What the last advance did. */
typedef struct mpm_step_report { int substeps; float substep_dt; int halvings; } mpm_step_report;
/* Advances by dt [s] and waits; `report` may be NULL. */
mpm_status mpm_scene_step(mpm_scene* scene, float dt, mpm_step_report* report);
/* Starts an advance on the scene's worker thread; mpm_scene_fetch_results waits for it
 * and gives its outcome (a divergence shows there). */
mpm_status mpm_scene_advance(mpm_scene* scene, float dt);
mpm_status mpm_scene_fetch_results(mpm_scene* scene, mpm_step_report* report);
/* Stops the running advance at its next substep boundary (from any thread); its fetch or
 * step then returns MPM_ERROR_CANCELLED with the scene as before that advance. */
mpm_status mpm_scene_cancel(mpm_scene* scene);
mpm_status mpm_scene_time(const mpm_scene* scene, double* time);

/* --- many scenes at once (mpm/scene_batch.h): data generation, reinforcement learning --- */
typedef struct mpm_batch mpm_batch;
/* A batch of `count` scenes (not owned; release the batch before them) advanced together:
 * on the CPU each scene runs on one of `threads` threads (0: all hardware threads), and
 * ends bit for bit where it would have stepped alone. A NULL or repeated scene is refused. */
mpm_status mpm_batch_create(mpm_scene* const* scenes, size_t count, int threads, mpm_batch** batch);
void mpm_batch_release(mpm_batch* batch); /* NULL is ignored */
/* Advances every scene by dt [s] and waits; `reports` (count entries) may be NULL. If a
 * scene diverged (its message names scenes[i]) it is as before the step; the others moved. */
mpm_status mpm_batch_step(mpm_batch* batch, float dt, mpm_step_report* reports);

/* --- particle objects (tissue) --- */
typedef struct mpm_material {
  int model;                 /* mpm_material_model */
  float youngs_modulus;      /* E [Pa] */
  float poisson_ratio;       /* in (-1, 0.5) */
  float density;             /* [kg/m^3] */
  float fracture_toughness;  /* G_c [J/m^2]; 0: cutting costs nothing */
} mpm_material;
typedef struct mpm_object_desc {
  int primitive;             /* mpm_primitive */
  mpm_vec3 center, half_extents; /* box half sizes; .y the half-height of a cylinder */
  float radius;              /* sphere, cylinder */
  int particles_per_cell_axis;
  mpm_material material;
  mpm_vec3 velocity, angular_velocity;
  mpm_triangle_mesh mesh;    /* MPM_PRIMITIVE_MESH: a closed mesh, placed with its origin at `center` */
  float mesh_cell_size;      /* MPM_PRIMITIVE_MESH: [m]; 0: dx / 2 */
} mpm_object_desc;
void mpm_object_desc_default(mpm_object_desc* desc);
mpm_status mpm_scene_add_object(mpm_scene* scene, const mpm_object_desc* desc, mpm_object_id* id);
mpm_status mpm_scene_remove_object(mpm_scene* scene, mpm_object_id id);
mpm_status mpm_scene_particle_count(const mpm_scene* scene, mpm_object_id id, size_t* count);
/* Per particle: positions [m], velocities [m/s] (capacity in particles), deformation
 * gradients F (9 floats each, row-major F[i][j], capacity in particles). */
mpm_status mpm_scene_read_positions(const mpm_scene* scene, mpm_object_id id, mpm_vec3* out, size_t capacity, size_t* count);
mpm_status mpm_scene_read_velocities(const mpm_scene* scene, mpm_object_id id, mpm_vec3* out, size_t capacity, size_t* count);
mpm_status mpm_scene_read_deformation_gradients(const mpm_scene* scene, mpm_object_id id, float* out, size_t capacity, size_t* count);

/* --- rigid shapes (one primitive or mesh; several: mpm_scene_add_compound_shape) --- */
typedef struct mpm_shape_desc {
  int geometry;              /* mpm_geometry: a plane is the half-space below the local x-z plane */
  mpm_vec3 half_extents;     /* box */
  float radius, half_height; /* sphere, capsule, cylinder */
  int axis;                  /* capsule, cylinder: 0 x, 1 y, 2 z */
  mpm_body_state state;
  int contact_mode;          /* mpm_contact_mode */
  float friction, drag;      /* mu_k >= 0; c_d in [0, 1] */
  float mass;                /* [kg]; 0: kinematic (moves as set) */
  mpm_vec3 inertia;          /* principal moments [kg m^2] (dynamic) */
  mpm_vec3 gravity;          /* felt by a dynamic shape between substeps */
  mpm_triangle_mesh mesh;    /* MPM_GEOMETRY_MESH: triangles in the shape's frame (closed: a solid) */
  float mesh_cell_size;      /* MPM_GEOMETRY_MESH: [m]; 0: dx / 2 */
} mpm_shape_desc;
void mpm_shape_desc_default(mpm_shape_desc* desc);
mpm_status mpm_scene_add_shape(mpm_scene* scene, const mpm_shape_desc* desc, mpm_shape_id* id);
/* One part of a compound shape: a primitive or a mesh (fields as in mpm_shape_desc) placed
 * at `local_pose` in the shape's frame (the frame of its state, its centre of mass). */
typedef struct mpm_shape_part {
  int geometry;              /* mpm_geometry */
  mpm_vec3 half_extents;
  float radius, half_height;
  int axis;
  mpm_triangle_mesh mesh;
  float mesh_cell_size;
  mpm_pose local_pose;
} mpm_shape_part;
void mpm_shape_part_default(mpm_shape_part* part);
/* A shape of `part_count` (>= 1) parts: one rigid body, its state, contact, mass, inertia
 * and gravity from `desc` (whose own geometry and mesh fields are not used). Its impulse is
 * the whole body's. */
mpm_status mpm_scene_add_compound_shape(mpm_scene* scene, const mpm_shape_desc* desc, const mpm_shape_part* parts,
                                        size_t part_count, mpm_shape_id* id);
mpm_status mpm_scene_remove_shape(mpm_scene* scene, mpm_shape_id id);
/* The pose and velocities the shape has and moves with over the next advance (a
 * kinematic shape's target; a dynamic one's state before it). */
mpm_status mpm_scene_set_shape_state(mpm_scene* scene, mpm_shape_id id, const mpm_body_state* state);
mpm_status mpm_scene_shape_state(const mpm_scene* scene, mpm_shape_id id, mpm_body_state* state);
mpm_status mpm_scene_shape_impulse(const mpm_scene* scene, mpm_shape_id id, mpm_impulse* impulse);

/* --- slicers (a straight blade: edge along local x at y = 0, spine at y = width) --- */
typedef struct mpm_quad_slicer_desc {
  float half_length, width, spine_radius, half_thickness, friction;
  mpm_body_state state;
} mpm_quad_slicer_desc;
void mpm_quad_slicer_desc_default(mpm_quad_slicer_desc* desc);
mpm_status mpm_scene_add_quad_slicer(mpm_scene* scene, const mpm_quad_slicer_desc* desc, mpm_slicer_id* id);
/* A curved blade: an open mesh in the slicer's frame, its triangles consistently oriented;
 * material beside it is cut (its boundary cuts too), only the spine (a round bar from
 * spine_from to spine_to, slicer frame) is blunt. */
typedef struct mpm_mesh_slicer_desc {
  mpm_triangle_mesh blade;
  mpm_vec3 spine_from, spine_to;
  float spine_radius;        /* [m]; 0: no spine */
  float half_thickness, friction;
  float sample_spacing;      /* of the blade's sampled distance [m]; 0: dx / 4 */
  mpm_body_state state;
} mpm_mesh_slicer_desc;
void mpm_mesh_slicer_desc_default(mpm_mesh_slicer_desc* desc);
mpm_status mpm_scene_add_mesh_slicer(mpm_scene* scene, const mpm_mesh_slicer_desc* desc, mpm_slicer_id* id);
mpm_status mpm_scene_remove_slicer(mpm_scene* scene, mpm_slicer_id id);
mpm_status mpm_scene_set_slicer_state(mpm_scene* scene, mpm_slicer_id id, const mpm_body_state* state);
mpm_status mpm_scene_slicer_impulse(const mpm_scene* scene, mpm_slicer_id id, mpm_impulse* impulse);

/* --- curves: an arc needle (in its local x-y plane about its frame's origin) --- */
typedef struct mpm_arc_desc {
  float radius, start_angle, end_angle, wire_radius, friction, puncture_force;
  mpm_body_state state;
} mpm_arc_desc;
void mpm_arc_desc_default(mpm_arc_desc* desc);
mpm_status mpm_scene_add_arc(mpm_scene* scene, const mpm_arc_desc* desc, mpm_curve_id* id);
mpm_status mpm_scene_remove_curve(mpm_scene* scene, mpm_curve_id id);
mpm_status mpm_scene_set_curve_state(mpm_scene* scene, mpm_curve_id id, const mpm_body_state* state);
mpm_status mpm_scene_curve_impulse(const mpm_scene* scene, mpm_curve_id id, mpm_impulse* impulse);
mpm_status mpm_scene_tip_inside(const mpm_scene* scene, mpm_curve_id id, int* inside);

/* --- curves: a thread, the polyline through point_count (>= 2) points [m] --- */
typedef struct mpm_line_segments_desc {
  const mpm_vec3* points;     /* point_count, copied */
  const mpm_vec3* velocities; /* point_count [m/s], or NULL: at rest */
  size_t point_count;
  float radius;               /* [m] */
  float friction, drag;       /* mu_k >= 0 and c_d in [0, 1] of the slip along the thread */
  float linear_density;       /* [kg/m]; 0: kinematic segments (they move as set) */
  mpm_vec3 gravity;           /* felt by dynamic segments within a step */
} mpm_line_segments_desc;
void mpm_line_segments_desc_default(mpm_line_segments_desc* desc);
mpm_status mpm_scene_add_line_segments(mpm_scene* scene, const mpm_line_segments_desc* desc, mpm_curve_id* id);
/* The thread's points (as many as it has) and their velocities (NULL: at rest) for the next
 * advance, e.g. from the links of the simulator's rope. */
mpm_status mpm_scene_set_curve_points(mpm_scene* scene, mpm_curve_id id, const mpm_vec3* points,
                                      const mpm_vec3* velocities, size_t point_count);
/* The impulse on each segment over the last advance, about its midpoint (point_count - 1
 * of them; a needle: one); mpm_scene_curve_impulse gives their sum about the first point.
 * Capacity in segments. */
mpm_status mpm_scene_segment_impulses(const mpm_scene* scene, mpm_curve_id id, mpm_impulse* out, size_t capacity,
                                      size_t* count);

/* --- checkpoints (the whole scene; bit for bit on the CPU backend) --- */
mpm_status mpm_scene_save(const mpm_scene* scene, const char* path);
mpm_status mpm_scene_load(mpm_scene* scene, const char* path);

#ifdef __cplusplus
}
#endif

#endif /* MPM_MPM_C_H */
