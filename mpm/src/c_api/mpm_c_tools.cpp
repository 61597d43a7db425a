// The C API's tools (mpm/mpm_c.h): quad and mesh slicers, needles (arcs) and threads
// (line segments), each call `guarded` as in mpm_c.cpp.
#include "c_api/c_support.h"

using namespace mpm::c_api;

extern "C" {

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

}  // extern "C"
