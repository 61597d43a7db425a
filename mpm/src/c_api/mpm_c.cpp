// The C API (mpm/mpm_c.h): plain structs in, mpm::Scene calls, status codes out. Every
// entry point runs inside `guarded`, so no exception crosses into C; the C++ message,
// which names the field and the value, becomes mpm_last_error() prefixed with the call.
#include "mpm/mpm_c.h"

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <memory>
#include <new>
#include <string>
#include <vector>

#include "mpm/curves.h"
#include "mpm/error.h"
#include "mpm/scene.h"
#include "mpm/scene_batch.h"
#include "mpm/sdf_grid.h"
#include "mpm/slicers.h"
#include "c_api/c_names.h"

struct mpm_scene {
  mpm::Scene scene;
};

struct mpm_batch {
  mpm::SceneBatch batch;
};

namespace {

thread_local std::string lastError;

struct BufferTooSmall : std::runtime_error {
  using std::runtime_error::runtime_error;
};

mpm_status fail(const char* call, mpm_status status, const std::string& what) {
  lastError = std::string(call) + ": " + mpm::c_api::cNames(what, call);  // the C header's names
  return status;
}

template <class F>
mpm_status guarded(const char* call, F&& body) noexcept {
  try {
    body();
    return MPM_OK;
  } catch (const BufferTooSmall& e) {
    return fail(call, MPM_ERROR_BUFFER_TOO_SMALL, e.what());
  } catch (const mpm::InvalidArgument& e) {
    return fail(call, MPM_ERROR_INVALID_ARGUMENT, e.what());
  } catch (const mpm::SimulationDiverged& e) {
    return fail(call, MPM_ERROR_SIMULATION_DIVERGED, e.what());
  } catch (const mpm::BackendUnavailable& e) {
    return fail(call, MPM_ERROR_BACKEND_UNAVAILABLE, e.what());
  } catch (const mpm::CheckpointError& e) {
    return fail(call, MPM_ERROR_CHECKPOINT, e.what());
  } catch (const mpm::OutOfMemory& e) {
    return fail(call, MPM_ERROR_OUT_OF_MEMORY, e.what());
  } catch (const std::bad_alloc&) {
    return fail(call, MPM_ERROR_OUT_OF_MEMORY, "out of memory");
  } catch (const mpm::StepInProgress& e) {
    return fail(call, MPM_ERROR_BUSY, e.what());
  } catch (const mpm::AdvanceCancelled& e) {
    return fail(call, MPM_ERROR_CANCELLED, e.what());
  } catch (const std::exception& e) {
    return fail(call, MPM_ERROR_INTERNAL, e.what());
  } catch (...) {
    return fail(call, MPM_ERROR_INTERNAL, "unknown exception");
  }
}

template <class T>
T& need(T* pointer, const char* field) {
  if (!pointer) throw mpm::InvalidArgument(field, "NULL", "must point to a value");
  return *pointer;
}

/// A C enum passed as int: one of `names` (0, 1, ... in order) or an error naming it.
template <class E>
E checkedEnum(int value, const std::vector<const char*>& names, const char* field) {
  if (value < 0 || value >= (int)names.size()) {
    std::string list;
    for (const char* n : names) list += (list.empty() ? "" : ", ") + std::string(n);
    throw mpm::InvalidArgument(field, std::to_string(value), "must be one of " + list);
  }
  return static_cast<E>(value);
}

mpm::Vec3f vec(mpm_vec3 v) { return {v.x, v.y, v.z}; }
mpm_vec3 vec(mpm::Vec3f v) { return {v.x, v.y, v.z}; }
mpm::ShapeState state(const mpm_body_state& s) {
  mpm::ShapeState r;
  r.pose.position = vec(s.pose.position);
  r.pose.rotation = {s.pose.rotation.w, s.pose.rotation.x, s.pose.rotation.y, s.pose.rotation.z};
  r.linearVelocity = vec(s.linear_velocity);
  r.angularVelocity = vec(s.angular_velocity);
  return r;
}
mpm_body_state state(const mpm::ShapeState& s) {
  const mpm::Quat& q = s.pose.rotation;
  return {{vec(s.pose.position), {q.w, q.x, q.y, q.z}}, vec(s.linearVelocity), vec(s.angularVelocity)};
}
mpm_body_state state(const mpm::Pose& pose, mpm::Vec3f v, mpm::Vec3f w) { return state(mpm::ShapeState{pose, v, w}); }
/// A description's pose and velocities (shapes, slicers, needles name them alike).
template <class Desc>
void placeBody(Desc& d, const mpm_body_state& s) {
  const mpm::ShapeState st = state(s);
  d.pose = st.pose;
  d.linearVelocity = st.linearVelocity;
  d.angularVelocity = st.angularVelocity;
}
mpm_impulse impulse(const mpm::ShapeImpulse& j) { return {vec(j.linear), vec(j.angular)}; }

mpm::ParticleObjectId object(mpm_object_id id) { return {id.index, id.generation}; }
mpm::ShapeId shape(mpm_shape_id id) { return {id.index, id.generation}; }
mpm::SlicerId slicer(mpm_slicer_id id) { return {id.index, id.generation}; }
mpm::CurveId curve(mpm_curve_id id) { return {id.index, id.generation}; }

/// Copies `values` to a caller's buffer of `capacity` elements, each `width` floats.
template <class T>
void copyOut(const std::vector<T>& values, float* out, size_t capacity, size_t* count, size_t width) {
  need(count, "count") = values.size();
  if (capacity < values.size())
    throw BufferTooSmall("capacity = " + std::to_string(capacity) + ": the object has " +
                         std::to_string(values.size()) + " particles");
  if (!values.empty()) need(out, "out");
  for (size_t i = 0; i < values.size(); ++i)
    for (size_t k = 0; k < width; ++k) out[i * width + k] = reinterpret_cast<const float*>(&values[i])[k];
}

const std::vector<const char*> kSolvers = {"MPM_SOLVER_MLS", "MPM_SOLVER_STANDARD", "MPM_SOLVER_PB", "MPM_SOLVER_MTLED"};
const std::vector<const char*> kBackends = {"MPM_BACKEND_AUTO", "MPM_BACKEND_CPU", "MPM_BACKEND_CUDA"};
const std::vector<const char*> kModels = {"MPM_FIXED_COROTATED", "MPM_NEO_HOOKEAN_DECOUPLED"};
const std::vector<const char*> kPrimitives = {"MPM_PRIMITIVE_BOX", "MPM_PRIMITIVE_SPHERE", "MPM_PRIMITIVE_CYLINDER",
                                              "MPM_PRIMITIVE_MESH"};
const std::vector<const char*> kGeometries = {"MPM_GEOMETRY_PLANE", "MPM_GEOMETRY_BOX", "MPM_GEOMETRY_SPHERE",
                                              "MPM_GEOMETRY_CAPSULE", "MPM_GEOMETRY_CYLINDER", "MPM_GEOMETRY_MESH"};
const std::vector<const char*> kContactModes = {"MPM_CONTACT_FRICTIONAL", "MPM_CONTACT_STICKY", "MPM_CONTACT_BONDED"};

mpm_step_report report(const mpm::StepReport& r) { return {r.substeps, r.substepDt, r.halvings}; }

std::string show(float v) {
  char text[32];
  std::snprintf(text, sizeof text, "%.9g", v);
  return text;
}

/// The caller's triangles, copied; `field` names the mpm_triangle_mesh (e.g.
/// "mpm_shape_desc.mesh") in errors.
mpm::TriangleMesh triangles(const mpm_triangle_mesh& m, const std::string& field) {
  if (m.vertex_count > 0 && !m.vertices)
    throw mpm::InvalidArgument(field + ".vertices", "NULL",
                               "must point to vertex_count = " + std::to_string(m.vertex_count) + " vertices");
  if (m.triangle_count > 0 && !m.indices)
    throw mpm::InvalidArgument(field + ".indices", "NULL",
                               "must point to 3 * triangle_count = 3 * " + std::to_string(m.triangle_count) + " indices");
  // a count no array holds (12 bytes a vertex, 12 an index triple): refused before copying
  if (m.vertex_count > SIZE_MAX / 12 || m.vertex_count > UINT32_MAX)
    throw mpm::InvalidArgument(field + ".vertex_count", std::to_string(m.vertex_count), "too many vertices");
  if (m.triangle_count > SIZE_MAX / 12)
    throw mpm::InvalidArgument(field + ".triangle_count", std::to_string(m.triangle_count), "too many triangles");
  mpm::TriangleMesh mesh;
  mesh.vertices.resize(m.vertex_count);
  for (size_t i = 0; i < m.vertex_count; ++i) mesh.vertices[i] = vec(m.vertices[i]);
  mesh.indices.assign(m.indices, m.indices + 3 * m.triangle_count);
  return mesh;
}

/// Runs a geometry call on the caller's mesh: its InvalidArgument on the mesh
/// ("TriangleMesh.indices[5]", "MeshSlicerDesc.blade") or the cell size ("cellSize") names
/// the C fields instead.
template <class F>
auto renamed(const std::string& meshField, const std::string& cellField, F&& build) {
  try {
    return build();
  } catch (const mpm::InvalidArgument& e) {
    const std::string& f = e.field();
    const std::string why = std::string(e.what()).substr(f.size() + 3 + e.value().size() + 2);
    if (f.compare(0, 13, "TriangleMesh.") == 0) throw mpm::InvalidArgument(meshField + f.substr(12), e.value(), why);
    if (f == "MeshSlicerDesc.blade") throw mpm::InvalidArgument(meshField, e.value(), why);
    if (f == "cellSize") throw mpm::InvalidArgument(cellField, e.value(), why);
    throw;
  }
}

/// The signed distance grid of the caller's mesh at `cell` [m] (0: dx / 2).
std::shared_ptr<const mpm::SignedDistanceGrid> meshGrid(const mpm_triangle_mesh& m, float cell, float dx,
                                                        const std::string& meshField, const std::string& cellField) {
  if (!std::isfinite(cell) || cell < 0.f)
    throw mpm::InvalidArgument(cellField, show(cell), "must be a finite number >= 0 (0: half the scene's dx)");
  const mpm::TriangleMesh mesh = triangles(m, meshField);
  const float h = cell > 0.f ? cell : 0.5f * dx;
  return std::make_shared<const mpm::SignedDistanceGrid>(
      renamed(meshField, cellField, [&] { return mpm::buildSignedDistanceGrid(mesh, h); }));
}

/// One part of a shape from the C fields (a one-primitive shape's or a compound's part).
mpm::Geometry geometry(int type, mpm_vec3 halfExtents, float radius, float halfHeight, int axis,
                       const mpm_triangle_mesh& mesh, float meshCell, float dx, const std::string& field) {
  mpm::Geometry g;
  g.type = checkedEnum<mpm::GeometryType>(type, kGeometries, (field + "geometry").c_str());
  g.halfExtents = vec(halfExtents);
  g.radius = radius;
  g.halfHeight = halfHeight;
  g.axis = axis;
  if (g.type == mpm::GeometryType::Mesh) g.sdf = meshGrid(mesh, meshCell, dx, field + "mesh", field + "mesh_cell_size");
  return g;
}

/// The body of a shape (everything but its parts) from the C description.
mpm::ShapeDesc shapeBody(const mpm_shape_desc& s) {
  mpm::ShapeDesc d;
  placeBody(d, s.state);
  d.contact.mode = checkedEnum<mpm::ContactMode>(s.contact_mode, kContactModes, "mpm_shape_desc.contact_mode");
  d.contact.friction = s.friction;
  d.contact.drag = s.drag;
  d.mass = s.mass;
  d.inertia = vec(s.inertia);
  d.gravity = vec(s.gravity);
  return d;
}

/// `count` points at `points` (and as many velocities, or none); `field` names them.
void points(const mpm_vec3* points, const mpm_vec3* velocities, size_t count, const std::string& field,
            std::vector<mpm::Vec3f>& x, std::vector<mpm::Vec3f>& v) {
  if (count > 0 && !points)
    throw mpm::InvalidArgument(field + "points", "NULL", "must point to point_count = " + std::to_string(count) + " points");
  if (count > SIZE_MAX / 24) throw mpm::InvalidArgument(field + "point_count", std::to_string(count), "too many points");
  x.resize(count);
  for (size_t i = 0; i < count; ++i) x[i] = vec(points[i]);
  v.clear();
  if (velocities) {
    v.resize(count);
    for (size_t i = 0; i < count; ++i) v[i] = vec(velocities[i]);
  }
}

}  // namespace

extern "C" {

const char* mpm_last_error(void) { return lastError.c_str(); }

void mpm_scene_settings_default(mpm_scene_settings* out) {
  if (!out) return;
  const mpm::SceneSettings d;
  *out = {vec(d.domain.lower), vec(d.domain.upper), d.dx, vec(d.gravity), (int)d.solver, (int)d.backend,
          d.cpuThreads, d.pbMpm.iterations, d.substeps.cflNumber};
}

mpm_status mpm_scene_create(const mpm_scene_settings* settings, mpm_scene** scene) {
  return guarded("mpm_scene_create", [&] {
    const mpm_scene_settings& s = need(settings, "settings");
    need(scene, "scene") = nullptr;
    mpm::SceneSettings d;
    d.domain.lower = vec(s.domain_lower);
    d.domain.upper = vec(s.domain_upper);
    d.dx = s.dx;
    d.gravity = vec(s.gravity);
    d.solver = checkedEnum<mpm::SolverType>(s.solver, kSolvers, "mpm_scene_settings.solver");
    d.backend = checkedEnum<mpm::Backend>(s.backend, kBackends, "mpm_scene_settings.backend");
    d.cpuThreads = s.cpu_threads;
    d.pbMpm.iterations = s.pb_iterations;
    d.substeps.cflNumber = s.cfl_number;
    *scene = new mpm_scene{mpm::Scene(d)};
  });
}

void mpm_scene_release(mpm_scene* scene) { delete scene; }

mpm_status mpm_scene_step(mpm_scene* scene, float dt, mpm_step_report* out) {
  return guarded("mpm_scene_step", [&] {
    const mpm::StepReport r = need(scene, "scene").scene.step(dt);
    if (out) *out = report(r);
  });
}

mpm_status mpm_scene_advance(mpm_scene* scene, float dt) {
  return guarded("mpm_scene_advance", [&] { need(scene, "scene").scene.advance(dt); });
}

mpm_status mpm_scene_cancel(mpm_scene* scene) {
  return guarded("mpm_scene_cancel", [&] { need(scene, "scene").scene.cancel(); });
}

mpm_status mpm_scene_fetch_results(mpm_scene* scene, mpm_step_report* out) {
  return guarded("mpm_scene_fetch_results", [&] {
    const mpm::StepReport r = need(scene, "scene").scene.fetchResults();
    if (out) *out = report(r);
  });
}

mpm_status mpm_scene_time(const mpm_scene* scene, double* time) {
  return guarded("mpm_scene_time", [&] { need(time, "time") = need(scene, "scene").scene.time(); });
}

mpm_status mpm_batch_create(mpm_scene* const* scenes, size_t count, int threads, mpm_batch** batch) {
  return guarded("mpm_batch_create", [&] {
    need(batch, "batch") = nullptr;
    if (count > 0) need(scenes, "scenes");
    std::vector<mpm::Scene*> list(count, nullptr);
    for (size_t i = 0; i < count; ++i)
      if (scenes[i]) list[i] = &scenes[i]->scene;  // a NULL entry is refused by SceneBatch, named
    *batch = new mpm_batch{mpm::SceneBatch(std::move(list), threads)};
  });
}

void mpm_batch_release(mpm_batch* batch) { delete batch; }

mpm_status mpm_batch_step(mpm_batch* batch, float dt, mpm_step_report* reports) {
  return guarded("mpm_batch_step", [&] {
    mpm::SceneBatch& b = need(batch, "batch").batch;
    std::vector<mpm::StepReport> r;
    try {
      r = b.step(dt);
    } catch (const mpm::SimulationDiverged& e) {  // which scene: the message says
      throw mpm::SimulationDiverged("scenes[" + std::to_string(b.failedScenes().front()) + "]: " + e.what());
    }
    if (reports)
      for (size_t i = 0; i < r.size(); ++i) reports[i] = report(r[i]);
  });
}

void mpm_object_desc_default(mpm_object_desc* out) {
  if (!out) return;
  const mpm::ParticleObjectDesc d;
  const mpm::Material& m = d.material;
  *out = {(int)d.primitive, vec(d.center), vec(d.halfExtents), d.radius, d.particlesPerCellAxis,
          {(int)m.model, m.youngsModulus, m.poissonRatio, m.density, m.fractureToughness},
          vec(d.velocity), vec(d.angularVelocity), {NULL, 0, NULL, 0}, 0.f};
}

mpm_status mpm_scene_add_object(mpm_scene* scene, const mpm_object_desc* desc, mpm_object_id* id) {
  return guarded("mpm_scene_add_object", [&] {
    const mpm_object_desc& s = need(desc, "desc");
    need(id, "id");
    mpm::ParticleObjectDesc d;
    d.primitive = checkedEnum<mpm::PrimitiveType>(s.primitive, kPrimitives, "mpm_object_desc.primitive");
    d.center = vec(s.center);
    d.halfExtents = vec(s.half_extents);
    d.radius = s.radius;
    d.particlesPerCellAxis = s.particles_per_cell_axis;
    d.material = {checkedEnum<mpm::MaterialModel>(s.material.model, kModels, "mpm_object_desc.material.model"),
                  s.material.youngs_modulus, s.material.poisson_ratio, s.material.density,
                  s.material.fracture_toughness};
    d.velocity = vec(s.velocity);
    d.angularVelocity = vec(s.angular_velocity);
    mpm::Scene& sc = need(scene, "scene").scene;
    if (d.primitive == mpm::PrimitiveType::Mesh)
      d.mesh = meshGrid(s.mesh, s.mesh_cell_size, sc.settings().dx, "mpm_object_desc.mesh", "mpm_object_desc.mesh_cell_size");
    const mpm::ParticleObjectId r = sc.addParticleObject(d);
    *id = {r.index, r.generation};
  });
}

mpm_status mpm_scene_remove_object(mpm_scene* scene, mpm_object_id id) {
  return guarded("mpm_scene_remove_object", [&] { need(scene, "scene").scene.removeParticleObject(object(id)); });
}

mpm_status mpm_scene_particle_count(const mpm_scene* scene, mpm_object_id id, size_t* count) {
  return guarded("mpm_scene_particle_count",
                 [&] { need(count, "count") = need(scene, "scene").scene.particleCount(object(id)); });
}

mpm_status mpm_scene_read_positions(const mpm_scene* scene, mpm_object_id id, mpm_vec3* out, size_t capacity,
                                    size_t* count) {
  return guarded("mpm_scene_read_positions", [&] {
    std::vector<mpm::Vec3f> x;
    need(scene, "scene").scene.readPositions(object(id), x);
    copyOut(x, reinterpret_cast<float*>(out), capacity, count, 3);
  });
}

mpm_status mpm_scene_read_velocities(const mpm_scene* scene, mpm_object_id id, mpm_vec3* out, size_t capacity,
                                     size_t* count) {
  return guarded("mpm_scene_read_velocities", [&] {
    std::vector<mpm::Vec3f> v;
    need(scene, "scene").scene.readVelocities(object(id), v);
    copyOut(v, reinterpret_cast<float*>(out), capacity, count, 3);
  });
}

mpm_status mpm_scene_read_deformation_gradients(const mpm_scene* scene, mpm_object_id id, float* out,
                                                size_t capacity, size_t* count) {
  return guarded("mpm_scene_read_deformation_gradients", [&] {
    std::vector<mpm::Mat3f> F;
    need(scene, "scene").scene.readDeformationGradients(object(id), F);
    copyOut(F, out, capacity, count, 9);  // Mat3f is m[3][3], row-major
  });
}

void mpm_shape_desc_default(mpm_shape_desc* out) {
  if (!out) return;
  const mpm::ShapeDesc d;
  const mpm::Geometry g;
  *out = {(int)g.type,       vec(g.halfExtents), g.radius,       g.halfHeight,
          g.axis,            state(d.pose, d.linearVelocity, d.angularVelocity),
          (int)d.contact.mode, d.contact.friction, d.contact.drag, d.mass,
          vec(d.inertia),    vec(d.gravity), {NULL, 0, NULL, 0}, 0.f};
}

void mpm_shape_part_default(mpm_shape_part* out) {
  if (!out) return;
  const mpm::Geometry g;
  const mpm::Quat& q = g.localPose.rotation;
  *out = {(int)g.type, vec(g.halfExtents), g.radius, g.halfHeight, g.axis, {NULL, 0, NULL, 0}, 0.f,
          {vec(g.localPose.position), {q.w, q.x, q.y, q.z}}};
}

mpm_status mpm_scene_add_shape(mpm_scene* scene, const mpm_shape_desc* desc, mpm_shape_id* id) {
  return guarded("mpm_scene_add_shape", [&] {
    const mpm_shape_desc& s = need(desc, "desc");
    need(id, "id");
    mpm::Scene& sc = need(scene, "scene").scene;
    mpm::ShapeDesc d = shapeBody(s);
    d.parts = {geometry(s.geometry, s.half_extents, s.radius, s.half_height, s.axis, s.mesh, s.mesh_cell_size,
                        sc.settings().dx, "mpm_shape_desc.")};
    const mpm::ShapeId r = sc.addShape(d);
    *id = {r.index, r.generation};
  });
}

mpm_status mpm_scene_add_compound_shape(mpm_scene* scene, const mpm_shape_desc* desc, const mpm_shape_part* parts,
                                        size_t part_count, mpm_shape_id* id) {
  return guarded("mpm_scene_add_compound_shape", [&] {
    const mpm_shape_desc& s = need(desc, "desc");
    need(id, "id");
    mpm::Scene& sc = need(scene, "scene").scene;
    if (part_count == 0) throw mpm::InvalidArgument("part_count", "0", "a shape needs at least one part");
    if (!parts) throw mpm::InvalidArgument("parts", "NULL", "must point to part_count = " + std::to_string(part_count) + " parts");
    if (part_count > 1000000) throw mpm::InvalidArgument("part_count", std::to_string(part_count), "must be <= 1000000");
    mpm::ShapeDesc d = shapeBody(s);
    for (size_t i = 0; i < part_count; ++i) {
      const mpm_shape_part& p = parts[i];
      const std::string field = "parts[" + std::to_string(i) + "].";
      mpm::Geometry g = geometry(p.geometry, p.half_extents, p.radius, p.half_height, p.axis, p.mesh, p.mesh_cell_size,
                                 sc.settings().dx, field);
      g.localPose.position = vec(p.local_pose.position);
      g.localPose.rotation = {p.local_pose.rotation.w, p.local_pose.rotation.x, p.local_pose.rotation.y,
                              p.local_pose.rotation.z};
      d.parts.push_back(std::move(g));
    }
    const mpm::ShapeId r = sc.addShape(d);
    *id = {r.index, r.generation};
  });
}

mpm_status mpm_scene_remove_shape(mpm_scene* scene, mpm_shape_id id) {
  return guarded("mpm_scene_remove_shape", [&] { need(scene, "scene").scene.removeShape(shape(id)); });
}

mpm_status mpm_scene_set_shape_state(mpm_scene* scene, mpm_shape_id id, const mpm_body_state* s) {
  return guarded("mpm_scene_set_shape_state",
                 [&] { need(scene, "scene").scene.setShapeState(shape(id), state(need(s, "state"))); });
}

mpm_status mpm_scene_shape_state(const mpm_scene* scene, mpm_shape_id id, mpm_body_state* out) {
  return guarded("mpm_scene_shape_state",
                 [&] { need(out, "state") = state(need(scene, "scene").scene.shapeState(shape(id))); });
}

mpm_status mpm_scene_shape_impulse(const mpm_scene* scene, mpm_shape_id id, mpm_impulse* out) {
  return guarded("mpm_scene_shape_impulse",
                 [&] { need(out, "impulse") = impulse(need(scene, "scene").scene.shapeImpulse(shape(id))); });
}

void mpm_quad_slicer_desc_default(mpm_quad_slicer_desc* out) {
  if (!out) return;
  const mpm::QuadSlicerDesc d;
  *out = {d.halfLength, d.width, d.spineRadius, d.halfThickness, d.friction,
          state(d.pose, d.linearVelocity, d.angularVelocity)};
}

mpm_status mpm_scene_add_quad_slicer(mpm_scene* scene, const mpm_quad_slicer_desc* desc, mpm_slicer_id* id) {
  return guarded("mpm_scene_add_quad_slicer", [&] {
    const mpm_quad_slicer_desc& s = need(desc, "desc");
    need(id, "id");
    mpm::QuadSlicerDesc d;
    d.halfLength = s.half_length;
    d.width = s.width;
    d.spineRadius = s.spine_radius;
    d.halfThickness = s.half_thickness;
    d.friction = s.friction;
    placeBody(d, s.state);
    const mpm::SlicerId r = need(scene, "scene").scene.addSlicer(d);
    *id = {r.index, r.generation};
  });
}

void mpm_mesh_slicer_desc_default(mpm_mesh_slicer_desc* out) {
  if (!out) return;
  const mpm::MeshSlicerDesc d;
  *out = {{NULL, 0, NULL, 0}, vec(d.spineFrom), vec(d.spineTo), d.spineRadius, d.halfThickness, d.friction,
          d.sampleSpacing, state(d.pose, d.linearVelocity, d.angularVelocity)};
}

mpm_status mpm_scene_add_mesh_slicer(mpm_scene* scene, const mpm_mesh_slicer_desc* desc, mpm_slicer_id* id) {
  return guarded("mpm_scene_add_mesh_slicer", [&] {
    const mpm_mesh_slicer_desc& s = need(desc, "desc");
    need(id, "id");
    mpm::Scene& sc = need(scene, "scene").scene;
    mpm::MeshSlicerDesc d;
    d.blade = triangles(s.blade, "mpm_mesh_slicer_desc.blade");
    d.spineFrom = vec(s.spine_from);
    d.spineTo = vec(s.spine_to);
    d.spineRadius = s.spine_radius;
    d.halfThickness = s.half_thickness;
    d.friction = s.friction;
    d.sampleSpacing = s.sample_spacing;
    placeBody(d, s.state);
    const mpm::SlicerId r = renamed("mpm_mesh_slicer_desc.blade", "mpm_mesh_slicer_desc.sample_spacing",
                                    [&] { return sc.addSlicer(d); });
    *id = {r.index, r.generation};
  });
}

mpm_status mpm_scene_remove_slicer(mpm_scene* scene, mpm_slicer_id id) {
  return guarded("mpm_scene_remove_slicer", [&] { need(scene, "scene").scene.removeSlicer(slicer(id)); });
}

mpm_status mpm_scene_set_slicer_state(mpm_scene* scene, mpm_slicer_id id, const mpm_body_state* s) {
  return guarded("mpm_scene_set_slicer_state",
                 [&] { need(scene, "scene").scene.setSlicerState(slicer(id), state(need(s, "state"))); });
}

mpm_status mpm_scene_slicer_impulse(const mpm_scene* scene, mpm_slicer_id id, mpm_impulse* out) {
  return guarded("mpm_scene_slicer_impulse",
                 [&] { need(out, "impulse") = impulse(need(scene, "scene").scene.slicerImpulse(slicer(id))); });
}

void mpm_arc_desc_default(mpm_arc_desc* out) {
  if (!out) return;
  const mpm::ArcDesc d;
  *out = {d.radius,   d.startAngle,    d.endAngle, d.wireRadius, d.friction,
          d.punctureForce, state(d.pose, d.linearVelocity, d.angularVelocity)};
}

mpm_status mpm_scene_add_arc(mpm_scene* scene, const mpm_arc_desc* desc, mpm_curve_id* id) {
  return guarded("mpm_scene_add_arc", [&] {
    const mpm_arc_desc& s = need(desc, "desc");
    need(id, "id");
    mpm::ArcDesc d;
    d.radius = s.radius;
    d.startAngle = s.start_angle;
    d.endAngle = s.end_angle;
    d.wireRadius = s.wire_radius;
    d.friction = s.friction;
    d.punctureForce = s.puncture_force;
    placeBody(d, s.state);
    const mpm::CurveId r = need(scene, "scene").scene.addCurve(d);
    *id = {r.index, r.generation};
  });
}

mpm_status mpm_scene_remove_curve(mpm_scene* scene, mpm_curve_id id) {
  return guarded("mpm_scene_remove_curve", [&] { need(scene, "scene").scene.removeCurve(curve(id)); });
}

mpm_status mpm_scene_set_curve_state(mpm_scene* scene, mpm_curve_id id, const mpm_body_state* s) {
  return guarded("mpm_scene_set_curve_state",
                 [&] { need(scene, "scene").scene.setCurveState(curve(id), state(need(s, "state"))); });
}

mpm_status mpm_scene_curve_impulse(const mpm_scene* scene, mpm_curve_id id, mpm_impulse* out) {
  return guarded("mpm_scene_curve_impulse",
                 [&] { need(out, "impulse") = impulse(need(scene, "scene").scene.curveImpulse(curve(id))); });
}

mpm_status mpm_scene_tip_inside(const mpm_scene* scene, mpm_curve_id id, int* inside) {
  return guarded("mpm_scene_tip_inside",
                 [&] { need(inside, "inside") = need(scene, "scene").scene.tipInside(curve(id)) ? 1 : 0; });
}

void mpm_line_segments_desc_default(mpm_line_segments_desc* out) {
  if (!out) return;
  const mpm::LineSegmentsDesc d;
  *out = {NULL, NULL, 0, d.radius, d.friction, d.drag, d.linearDensity, vec(d.gravity)};
}

mpm_status mpm_scene_add_line_segments(mpm_scene* scene, const mpm_line_segments_desc* desc, mpm_curve_id* id) {
  return guarded("mpm_scene_add_line_segments", [&] {
    const mpm_line_segments_desc& s = need(desc, "desc");
    need(id, "id");
    mpm::LineSegmentsDesc d;
    points(s.points, s.velocities, s.point_count, "mpm_line_segments_desc.", d.points, d.velocities);
    d.radius = s.radius;
    d.friction = s.friction;
    d.drag = s.drag;
    d.linearDensity = s.linear_density;
    d.gravity = vec(s.gravity);
    const mpm::CurveId r = need(scene, "scene").scene.addCurve(d);
    *id = {r.index, r.generation};
  });
}

mpm_status mpm_scene_set_curve_points(mpm_scene* scene, mpm_curve_id id, const mpm_vec3* xs, const mpm_vec3* vs,
                                      size_t point_count) {
  return guarded("mpm_scene_set_curve_points", [&] {
    mpm::Scene& sc = need(scene, "scene").scene;
    std::vector<mpm::Vec3f> x, v;
    points(xs, vs, point_count, "", x, v);
    sc.setCurvePoints(curve(id), x, v);
  });
}

mpm_status mpm_scene_segment_impulses(const mpm_scene* scene, mpm_curve_id id, mpm_impulse* out, size_t capacity,
                                      size_t* count) {
  return guarded("mpm_scene_segment_impulses", [&] {
    const std::vector<mpm::ShapeImpulse> j = need(scene, "scene").scene.segmentImpulses(curve(id));
    need(count, "count") = j.size();
    if (capacity < j.size())
      throw BufferTooSmall("capacity = " + std::to_string(capacity) + ": the curve has " + std::to_string(j.size()) +
                           " segments");
    if (!j.empty()) need(out, "out");
    for (size_t i = 0; i < j.size(); ++i) out[i] = impulse(j[i]);
  });
}

mpm_status mpm_scene_save(const mpm_scene* scene, const char* path) {
  return guarded("mpm_scene_save", [&] { need(scene, "scene").scene.save(&need(path, "path")); });
}

mpm_status mpm_scene_load(mpm_scene* scene, const char* path) {
  return guarded("mpm_scene_load", [&] { need(scene, "scene").scene.load(&need(path, "path")); });
}

}  // extern "C"
