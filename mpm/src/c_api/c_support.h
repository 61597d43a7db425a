#pragma once
// What the C API's files share (mpm_c.cpp: scenes, objects, shapes, batches; mpm_c_tools.cpp:
// slicers, needles and threads): the handles' structs, `guarded`, which keeps every
// exception out of C, and the conversions between the C structs and the library's.
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

namespace mpm::c_api {


inline thread_local std::string lastError;

struct BufferTooSmall : std::runtime_error {
  using std::runtime_error::runtime_error;
};

inline mpm_status fail(const char* call, mpm_status status, const std::string& what) {
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

inline mpm::Vec3f vec(mpm_vec3 v) { return {v.x, v.y, v.z}; }
inline mpm_vec3 vec(mpm::Vec3f v) { return {v.x, v.y, v.z}; }
inline mpm::ShapeState state(const mpm_body_state& s) {
  mpm::ShapeState r;
  r.pose.position = vec(s.pose.position);
  r.pose.rotation = {s.pose.rotation.w, s.pose.rotation.x, s.pose.rotation.y, s.pose.rotation.z};
  r.linearVelocity = vec(s.linear_velocity);
  r.angularVelocity = vec(s.angular_velocity);
  return r;
}
inline mpm_body_state state(const mpm::ShapeState& s) {
  const mpm::Quat& q = s.pose.rotation;
  return {{vec(s.pose.position), {q.w, q.x, q.y, q.z}}, vec(s.linearVelocity), vec(s.angularVelocity)};
}
inline mpm_body_state state(const mpm::Pose& pose, mpm::Vec3f v, mpm::Vec3f w) { return state(mpm::ShapeState{pose, v, w}); }
/// A description's pose and velocities (shapes, slicers, needles name them alike).
template <class Desc>
void placeBody(Desc& d, const mpm_body_state& s) {
  const mpm::ShapeState st = state(s);
  d.pose = st.pose;
  d.linearVelocity = st.linearVelocity;
  d.angularVelocity = st.angularVelocity;
}
inline mpm_impulse impulse(const mpm::ShapeImpulse& j) { return {vec(j.linear), vec(j.angular)}; }

inline mpm::ParticleObjectId object(mpm_object_id id) { return {id.index, id.generation}; }
inline mpm::ShapeId shape(mpm_shape_id id) { return {id.index, id.generation}; }
inline mpm::SlicerId slicer(mpm_slicer_id id) { return {id.index, id.generation}; }
inline mpm::CurveId curve(mpm_curve_id id) { return {id.index, id.generation}; }

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

inline mpm_step_report report(const mpm::StepReport& r) { return {r.substeps, r.substepDt, r.halvings}; }

inline std::string show(float v) {
  char text[32];
  std::snprintf(text, sizeof text, "%.9g", v);
  return text;
}

/// The caller's triangles, copied; `field` names the mpm_triangle_mesh (e.g.
/// "mpm_shape_desc.mesh") in errors.
inline mpm::TriangleMesh triangles(const mpm_triangle_mesh& m, const std::string& field) {
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
inline std::shared_ptr<const mpm::SignedDistanceGrid> meshGrid(const mpm_triangle_mesh& m, float cell, float dx,
                                                        const std::string& meshField, const std::string& cellField) {
  if (!std::isfinite(cell) || cell < 0.f)
    throw mpm::InvalidArgument(cellField, show(cell), "must be a finite number >= 0 (0: half the scene's dx)");
  const mpm::TriangleMesh mesh = triangles(m, meshField);
  const float h = cell > 0.f ? cell : 0.5f * dx;
  return std::make_shared<const mpm::SignedDistanceGrid>(
      renamed(meshField, cellField, [&] { return mpm::buildSignedDistanceGrid(mesh, h); }));
}

/// One part of a shape from the C fields (a one-primitive shape's or a compound's part).
inline mpm::Geometry geometry(int type, mpm_vec3 halfExtents, float radius, float halfHeight, int axis,
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
inline mpm::ShapeDesc shapeBody(const mpm_shape_desc& s) {
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
inline void points(const mpm_vec3* points, const mpm_vec3* velocities, size_t count, const std::string& field,
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


}  // namespace mpm::c_api
