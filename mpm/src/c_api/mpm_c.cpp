// The C API (mpm/mpm_c.h): plain structs in, mpm::Scene calls, status codes out. Every
// entry point runs inside `guarded`, so no exception crosses into C; the C++ message,
// which names the field and the value, becomes mpm_last_error() prefixed with the call.
#include "mpm/mpm_c.h"

#include "c_api/c_support.h"

using namespace mpm::c_api;

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

mpm_status mpm_scene_save(const mpm_scene* scene, const char* path) {
  return guarded("mpm_scene_save", [&] { need(scene, "scene").scene.save(&need(path, "path")); });
}

mpm_status mpm_scene_load(mpm_scene* scene, const char* path) {
  return guarded("mpm_scene_load", [&] { need(scene, "scene").scene.load(&need(path, "path")); });
}

}  // extern "C"
