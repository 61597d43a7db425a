// Rigid shapes: parts as dicts ({"type": "box", "halfExtents": [...]}, a mesh from vertex and
// triangle arrays through the library's SDF sampling), pose and velocities as arguments,
// states and impulses as numpy arrays. Values are checked by the library (Scene::addShape),
// whose messages name the C++ field ("ShapeDesc.parts[0].radius = -1: must be > 0").
#include <pybind11/stl.h>

#include <set>

#include "bindings.h"

namespace mpm::python {

namespace {

/// A dict read key by key; a key nobody read is refused (a typo), as the scene files do.
class DictReader {
 public:
  DictReader(py::handle d, std::string name) : name_(std::move(name)) {
    if (!PyDict_Check(d.ptr())) throw InvalidArgument(name_, shown(d), "must be a dict");
    d_ = py::reinterpret_borrow<py::dict>(d);
  }
  std::string at(const char* key) const { return name_ + "." + key; }
  py::object get(const char* key) {
    seen_.insert(key);
    return d_.contains(key) ? py::object(d_[key]) : py::object();
  }
  void finish() const {
    for (auto item : d_) {
      const std::string key = py::str(item.first);
      if (!seen_.count(key)) throw InvalidArgument(name_ + "." + key, shown(item.second), "unknown key");
    }
  }

 private:
  py::dict d_;
  std::string name_;
  std::set<std::string> seen_;
};

float number(py::handle v, const std::string& name) {
  if (PyBool_Check(v.ptr()) || !PyNumber_Check(v.ptr())) throw InvalidArgument(name, shown(v), "must be a number");
  return (float)py::cast<double>(py::reinterpret_steal<py::object>(PyNumber_Float(v.ptr())));
}

Geometry readPart(py::handle part, const std::string& name, float dx) {
  DictReader r(part, name);
  Geometry g;
  const py::object type = r.get("type");
  if (!type) throw InvalidArgument(r.at("type"), "missing", "required: box, sphere, capsule, cylinder, plane or mesh");
  const std::string t = PyUnicode_Check(type.ptr()) ? type.cast<std::string>() : "";
  static const std::pair<const char*, GeometryType> kTypes[] = {
      {"box", GeometryType::Box},           {"sphere", GeometryType::Sphere}, {"capsule", GeometryType::Capsule},
      {"cylinder", GeometryType::Cylinder}, {"plane", GeometryType::Plane},   {"mesh", GeometryType::Mesh}};
  bool known = false;
  for (const auto& [n, v] : kTypes)
    if (t == n) g.type = v, known = true;
  if (!known) throw InvalidArgument(r.at("type"), shown(type), "must be one of box, sphere, capsule, cylinder, plane, mesh");
  if (py::object v = r.get("halfExtents")) g.halfExtents = toVec3(v, r.at("halfExtents"));
  if (py::object v = r.get("radius")) g.radius = number(v, r.at("radius"));
  if (py::object v = r.get("halfHeight")) g.halfHeight = number(v, r.at("halfHeight"));
  if (py::object v = r.get("axis")) {
    if (!PyLong_Check(v.ptr()) || PyBool_Check(v.ptr())) throw InvalidArgument(r.at("axis"), shown(v), "must be 0, 1 or 2");
    g.axis = v.cast<int>();
  }
  if (py::object v = r.get("position")) g.localPose.position = toVec3(v, r.at("position"));
  if (py::object v = r.get("orientation")) g.localPose.rotation = toQuat(v, r.at("orientation"));
  const py::object vertices = r.get("vertices"), triangles = r.get("triangles"), cell = r.get("cellSize");
  if (g.type == GeometryType::Mesh) {
    if (!vertices) throw InvalidArgument(r.at("vertices"), "missing", "required for a mesh");
    if (!triangles) throw InvalidArgument(r.at("triangles"), "missing", "required for a mesh");
    const TriangleMesh mesh = toMesh(vertices, triangles, name);
    const float h = cell ? number(cell, r.at("cellSize")) : 0.5f * dx;
    if (!(h > 0.f)) throw InvalidArgument(r.at("cellSize"), shown(cell), "must be > 0");
    r.finish();
    py::gil_scoped_release release;  // sampling a fine grid takes a while
    g.sdf = std::make_shared<const SignedDistanceGrid>(buildSignedDistanceGrid(mesh, h));
  } else {
    if (vertices || triangles || cell) {
      const char* key = vertices ? "vertices" : triangles ? "triangles" : "cellSize";
      throw InvalidArgument(r.at(key), shown(vertices ? vertices : triangles ? triangles : cell), "only for a mesh");
    }
    r.finish();
  }
  return g;
}

ContactParams readContact(py::handle contact) {
  ContactParams c;
  if (contact.is_none()) return c;
  DictReader r(contact, "contact");
  if (py::object v = r.get("mode")) {
    const std::string m = PyUnicode_Check(v.ptr()) ? v.cast<std::string>() : "";
    if (m == "frictional") c.mode = ContactMode::Frictional;
    else if (m == "sticky") c.mode = ContactMode::Sticky;
    else if (m == "bonded") c.mode = ContactMode::Bonded;
    else throw InvalidArgument(r.at("mode"), shown(v), "must be one of frictional, sticky, bonded");
  }
  if (py::object v = r.get("friction")) c.friction = number(v, r.at("friction"));
  if (py::object v = r.get("drag")) c.drag = number(v, r.at("drag"));
  if (py::object v = r.get("band")) c.band = number(v, r.at("band"));
  r.finish();
  return c;
}

}  // namespace

void bindShapes(SceneClass& c) {
  const ShapeDesc defaults;
  c.def(
      "add_shape",
      [](PyScene& s, py::list parts, py::handle position, py::handle orientation, py::handle linearVelocity,
         py::handle angularVelocity, py::handle centerOfMass, float mass, py::handle inertia, py::handle gravity,
         py::handle contact) {
        ShapeDesc d;
        for (size_t i = 0; i < parts.size(); ++i)
          d.parts.push_back(readPart(parts[i], "parts[" + std::to_string(i) + "]", s.scene().settings().dx));
        const ShapeState st = toState(position, orientation, linearVelocity, angularVelocity);
        d.pose = st.pose;
        d.linearVelocity = st.linearVelocity;
        d.angularVelocity = st.angularVelocity;
        d.centerOfMass = toVec3(centerOfMass, "center_of_mass");
        d.mass = mass;
        d.inertia = toVec3(inertia, "inertia");
        d.gravity = toVec3(gravity, "gravity");
        d.contact = readContact(contact);
        return s.scene().addShape(d);
      },
      py::arg("parts"), py::arg("position") = py::make_tuple(0, 0, 0), py::arg("orientation") = py::make_tuple(0, 0, 0, 1),
      py::arg("linear_velocity") = py::make_tuple(0, 0, 0), py::arg("angular_velocity") = py::make_tuple(0, 0, 0),
      py::arg("center_of_mass") = py::make_tuple(0, 0, 0), py::arg("mass") = defaults.mass,
      py::arg("inertia") = py::make_tuple(0, 0, 0), py::arg("gravity") = py::make_tuple(0, 0, 0),
      py::arg("contact") = py::none(),
      "Adds a rigid shape from part dicts (box, sphere, capsule, cylinder, plane, mesh). mass 0: kinematic. "
      "contact: {mode: frictional|sticky|bonded, friction, drag, band}. Returns its ShapeId.");
  c.def("remove_shape", [](PyScene& s, ShapeId id) { s.scene().removeShape(id); }, py::arg("shape"));
  c.def(
      "set_shape_state",
      [](PyScene& s, ShapeId id, py::handle p, py::handle q, py::handle v, py::handle w) {
        s.scene().setShapeState(id, toState(p, q, v, w));
      },
      py::arg("shape"), py::arg("position"), py::arg("orientation"), py::arg("linear_velocity") = py::make_tuple(0, 0, 0),
      py::arg("angular_velocity") = py::make_tuple(0, 0, 0),
      "Pose (orientation x, y, z, w) and velocities before an advance; the shape moves on with them.");
  c.def("shape_state", [](const PyScene& s, ShapeId id) { return stateTuple(s.scene().shapeState(id)); },
        py::arg("shape"), "(position, orientation (x, y, z, w), linear_velocity, angular_velocity) after the last advance.");
  c.def("shape_impulse", [](const PyScene& s, ShapeId id) { return impulseTuple(s.scene().shapeImpulse(id)); },
        py::arg("shape"),
        "(linear [N s], angular [N m s]) the grid gave the shape over the last advance, world frame, about its centre of mass.");
}

}  // namespace mpm::python
