// The C API (mpm/mpm_c.h): plain structs in, mpm::Scene calls, status codes out. Every
// entry point runs inside `guarded`, so no exception crosses into C; the C++ message,
// which names the field and the value, becomes mpm_last_error() prefixed with the call.
#include "mpm/mpm_c.h"

#include <new>
#include <string>
#include <vector>

#include "mpm/error.h"
#include "mpm/scene.h"

struct mpm_scene {
  mpm::Scene scene;
};

namespace {

thread_local std::string lastError;

struct BufferTooSmall : std::runtime_error {
  using std::runtime_error::runtime_error;
};

mpm_status fail(const char* call, mpm_status status, const std::string& what) {
  lastError = std::string(call) + ": " + what;
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
  } catch (const std::bad_alloc&) {
    return fail(call, MPM_ERROR_OUT_OF_MEMORY, "out of memory");
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
const std::vector<const char*> kPrimitives = {"MPM_PRIMITIVE_BOX", "MPM_PRIMITIVE_SPHERE", "MPM_PRIMITIVE_CYLINDER"};
const std::vector<const char*> kGeometries = {"MPM_GEOMETRY_PLANE", "MPM_GEOMETRY_BOX", "MPM_GEOMETRY_SPHERE",
                                              "MPM_GEOMETRY_CAPSULE", "MPM_GEOMETRY_CYLINDER"};
const std::vector<const char*> kContactModes = {"MPM_CONTACT_FRICTIONAL", "MPM_CONTACT_STICKY", "MPM_CONTACT_BONDED"};

mpm_step_report report(const mpm::StepReport& r) { return {r.substeps, r.substepDt, r.halvings}; }

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

mpm_status mpm_scene_fetch_results(mpm_scene* scene, mpm_step_report* out) {
  return guarded("mpm_scene_fetch_results", [&] {
    const mpm::StepReport r = need(scene, "scene").scene.fetchResults();
    if (out) *out = report(r);
  });
}

mpm_status mpm_scene_time(const mpm_scene* scene, double* time) {
  return guarded("mpm_scene_time", [&] { need(time, "time") = need(scene, "scene").scene.time(); });
}

void mpm_object_desc_default(mpm_object_desc* out) {
  if (!out) return;
  const mpm::ParticleObjectDesc d;
  const mpm::Material& m = d.material;
  *out = {(int)d.primitive, vec(d.center), vec(d.halfExtents), d.radius, d.particlesPerCellAxis,
          {(int)m.model, m.youngsModulus, m.poissonRatio, m.density, m.fractureToughness},
          vec(d.velocity), vec(d.angularVelocity)};
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
    const mpm::ParticleObjectId r = need(scene, "scene").scene.addParticleObject(d);
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
          vec(d.inertia),    vec(d.gravity)};
}

mpm_status mpm_scene_add_shape(mpm_scene* scene, const mpm_shape_desc* desc, mpm_shape_id* id) {
  return guarded("mpm_scene_add_shape", [&] {
    const mpm_shape_desc& s = need(desc, "desc");
    need(id, "id");
    mpm::Geometry g;
    g.type = checkedEnum<mpm::GeometryType>(s.geometry, kGeometries, "mpm_shape_desc.geometry");
    g.halfExtents = vec(s.half_extents);
    g.radius = s.radius;
    g.halfHeight = s.half_height;
    g.axis = s.axis;
    mpm::ShapeDesc d;
    d.parts = {g};
    placeBody(d, s.state);
    d.contact.mode = checkedEnum<mpm::ContactMode>(s.contact_mode, kContactModes, "mpm_shape_desc.contact_mode");
    d.contact.friction = s.friction;
    d.contact.drag = s.drag;
    d.mass = s.mass;
    d.inertia = vec(s.inertia);
    d.gravity = vec(s.gravity);
    const mpm::ShapeId r = need(scene, "scene").scene.addShape(d);
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

mpm_status mpm_scene_save(const mpm_scene* scene, const char* path) {
  return guarded("mpm_scene_save", [&] { need(scene, "scene").scene.save(&need(path, "path")); });
}

mpm_status mpm_scene_load(mpm_scene* scene, const char* path) {
  return guarded("mpm_scene_load", [&] { need(scene, "scene").scene.load(&need(path, "path")); });
}

}  // extern "C"
