// Surgical tools: slicers (quad and mesh blades, mpm/slicers.h) and curves (needle arcs and
// threads, mpm/curves.h). Keyword arguments carry the C++ fields' names in snake case;
// their defaults are the C++ descriptions' defaults.
#include <pybind11/stl.h>

#include <cstring>

#include "bindings.h"

namespace mpm::python {

namespace {

std::vector<Vec3f> optionalPoints(py::handle v, const std::string& name) {
  return v.is_none() ? std::vector<Vec3f>{} : toPoints(v, name);
}

}  // namespace

void bindTools(SceneClass& c) {
  const py::tuple zero = py::make_tuple(0, 0, 0), identity = py::make_tuple(0, 0, 0, 1);

  // --- slicers
  const QuadSlicerDesc quad;
  c.def(
      "add_quad_slicer",
      [](PyScene& s, float halfLength, float width, float spineRadius, float halfThickness, float friction,
         py::handle p, py::handle q, py::handle v, py::handle w) {
        QuadSlicerDesc d;
        d.halfLength = halfLength, d.width = width, d.spineRadius = spineRadius;
        d.halfThickness = halfThickness, d.friction = friction;
        const ShapeState st = toState(p, q, v, w);
        d.pose = st.pose, d.linearVelocity = st.linearVelocity, d.angularVelocity = st.angularVelocity;
        return s.scene().addSlicer(d);
      },
      py::arg("half_length") = quad.halfLength, py::arg("width") = quad.width, py::arg("spine_radius") = quad.spineRadius,
      py::arg("half_thickness") = quad.halfThickness, py::arg("friction") = quad.friction, py::arg("position") = zero,
      py::arg("orientation") = identity, py::arg("linear_velocity") = zero, py::arg("angular_velocity") = zero,
      "A rectangular blade: edge along local x (+-half_length) at y = 0, faces in z = 0 up to the spine at y = width.");
  const MeshSlicerDesc meshBlade;
  c.def(
      "add_mesh_slicer",
      [](PyScene& s, py::handle vertices, py::handle triangles, py::handle spineFrom, py::handle spineTo,
         float spineRadius, float halfThickness, float friction, float sampleSpacing, py::handle p, py::handle q,
         py::handle v, py::handle w) {
        MeshSlicerDesc d;
        d.blade = toMesh(vertices, triangles, "blade");
        d.spineFrom = toVec3(spineFrom, "spine_from"), d.spineTo = toVec3(spineTo, "spine_to");
        d.spineRadius = spineRadius, d.halfThickness = halfThickness, d.friction = friction;
        d.sampleSpacing = sampleSpacing;
        const ShapeState st = toState(p, q, v, w);
        d.pose = st.pose, d.linearVelocity = st.linearVelocity, d.angularVelocity = st.angularVelocity;
        return PyScene::Released(s, "add_mesh_slicer").scene().addSlicer(d);  // samples the blade's distance
      },
      py::arg("vertices"), py::arg("triangles"), py::arg("spine_from") = zero, py::arg("spine_to") = zero,
      py::arg("spine_radius") = meshBlade.spineRadius, py::arg("half_thickness") = meshBlade.halfThickness,
      py::arg("friction") = meshBlade.friction, py::arg("sample_spacing") = meshBlade.sampleSpacing,
      py::arg("position") = zero, py::arg("orientation") = identity, py::arg("linear_velocity") = zero,
      py::arg("angular_velocity") = zero, "A curved blade from an open, consistently oriented triangle mesh.");
  c.def("remove_slicer", [](PyScene& s, SlicerId id) { s.scene().removeSlicer(id); }, py::arg("slicer"));
  c.def(
      "set_slicer_state",
      [](PyScene& s, SlicerId id, py::handle p, py::handle q, py::handle v, py::handle w) {
        s.scene().setSlicerState(id, toState(p, q, v, w));
      },
      py::arg("slicer"), py::arg("position"), py::arg("orientation"), py::arg("linear_velocity") = zero,
      py::arg("angular_velocity") = zero);
  c.def("slicer_state", [](const PyScene& s, SlicerId id) { return stateTuple(s.scene().slicerState(id)); },
        py::arg("slicer"));
  c.def("slicer_impulse", [](const PyScene& s, SlicerId id) { return impulseTuple(s.scene().slicerImpulse(id)); },
        py::arg("slicer"), "(linear, angular) the material gave the blade, about its frame's origin.");

  // --- curves
  const ArcDesc arc;
  c.def(
      "add_arc",
      [](PyScene& s, float radius, float startAngle, float endAngle, float wireRadius, float friction,
         float punctureForce, py::handle p, py::handle q, py::handle v, py::handle w) {
        ArcDesc d;
        d.radius = radius, d.startAngle = startAngle, d.endAngle = endAngle, d.wireRadius = wireRadius;
        d.friction = friction, d.punctureForce = punctureForce;
        const ShapeState st = toState(p, q, v, w);
        d.pose = st.pose, d.linearVelocity = st.linearVelocity, d.angularVelocity = st.angularVelocity;
        return s.scene().addCurve(d);
      },
      py::arg("radius") = arc.radius, py::arg("start_angle") = arc.startAngle, py::arg("end_angle") = arc.endAngle,
      py::arg("wire_radius") = arc.wireRadius, py::arg("friction") = arc.friction,
      py::arg("puncture_force") = arc.punctureForce, py::arg("position") = zero, py::arg("orientation") = identity,
      py::arg("linear_velocity") = zero, py::arg("angular_velocity") = zero,
      "A circular needle in its local x-y plane, from start_angle (tail) to end_angle (tip) [rad].");
  const LineSegmentsDesc thread;
  c.def(
      "add_line_segments",
      [](PyScene& s, py::handle points, py::handle velocities, float radius, float friction, float drag,
         float linearDensity, py::handle gravity) {
        LineSegmentsDesc d;
        d.points = toPoints(points, "points");
        d.velocities = optionalPoints(velocities, "velocities");
        d.radius = radius, d.friction = friction, d.drag = drag, d.linearDensity = linearDensity;
        d.gravity = toVec3(gravity, "gravity");
        return s.scene().addCurve(d);
      },
      py::arg("points"), py::arg("velocities") = py::none(), py::arg("radius") = thread.radius,
      py::arg("friction") = thread.friction, py::arg("drag") = thread.drag,
      py::arg("linear_density") = thread.linearDensity, py::arg("gravity") = zero,
      "A thread: the polyline through points (N, 3) [m]; linear_density 0: kinematic segments.");
  c.def("remove_curve", [](PyScene& s, CurveId id) { s.scene().removeCurve(id); }, py::arg("curve"));
  c.def(
      "set_curve_state",
      [](PyScene& s, CurveId id, py::handle p, py::handle q, py::handle v, py::handle w) {
        s.scene().setCurveState(id, toState(p, q, v, w));
      },
      py::arg("curve"), py::arg("position"), py::arg("orientation"), py::arg("linear_velocity") = zero,
      py::arg("angular_velocity") = zero, "A needle's pose and velocities before an advance.");
  c.def("curve_state", [](const PyScene& s, CurveId id) { return stateTuple(s.scene().curveState(id)); },
        py::arg("curve"));
  c.def(
      "set_curve_points",
      [](PyScene& s, CurveId id, py::handle points, py::handle velocities) {
        s.scene().setCurvePoints(id, toPoints(points, "points"), optionalPoints(velocities, "velocities"));
      },
      py::arg("curve"), py::arg("points"), py::arg("velocities") = py::none(),
      "A thread's points and their velocities (N, 3) before an advance.");
  c.def("curve_impulse", [](const PyScene& s, CurveId id) { return impulseTuple(s.scene().curveImpulse(id)); },
        py::arg("curve"));
  c.def(
      "segment_impulses",
      [](const PyScene& s, CurveId id) {
        const std::vector<ShapeImpulse> v = s.scene().segmentImpulses(id);
        py::array_t<float> a(std::vector<py::ssize_t>{(py::ssize_t)v.size(), 2, 3});
        static_assert(sizeof(ShapeImpulse) == 6 * sizeof(float), "two packed Vec3f");
        if (!v.empty()) std::memcpy(a.mutable_data(), v.data(), v.size() * sizeof(ShapeImpulse));
        return a;
      },
      py::arg("curve"), "(n, 2, 3): each segment's (linear, angular) impulse, about its midpoint.");
  c.def("tip_inside", [](const PyScene& s, CurveId id) { return s.scene().tipInside(id); }, py::arg("curve"));
}

}  // namespace mpm::python
