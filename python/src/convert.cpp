// Python values to the library's types and back. Quaternions are (x, y, z, w) in Python,
// as pybullet has them, and (w, x, y, z) in mpm::Quat.
#include <cstring>

#include "bindings.h"

namespace mpm::python {

namespace {

/// A number from anything Python takes as one (float, int, numpy scalar); bools are refused.
float toFloat(py::handle v, const std::string& name) {
  if (PyBool_Check(v.ptr()) || !PyNumber_Check(v.ptr())) throw InvalidArgument(name, shown(v), "must be a number");
  const double d = py::cast<double>(py::reinterpret_steal<py::object>(PyNumber_Float(v.ptr())));
  return (float)d;
}

/// A float32 array of shape (n, 3) copied from any sequence of triples.
py::array_t<float> rows3(py::handle value, const std::string& name) {
  py::array_t<float, py::array::c_style | py::array::forcecast> a;
  try {
    a = py::array_t<float, py::array::c_style | py::array::forcecast>::ensure(value);
  } catch (const py::error_already_set&) {
  }
  if (!a || a.ndim() != 2 || a.shape(1) != 3) {
    PyErr_Clear();
    throw InvalidArgument(name, shown(value), "must be an array of shape (N, 3) of numbers");
  }
  return a;
}

}  // namespace

std::string shown(py::handle value) {
  std::string s;
  try {
    s = py::repr(value).cast<std::string>();
  } catch (const py::error_already_set&) {
    s = "?";
  }
  if (s.size() > 60) s = s.substr(0, 57) + "...";
  return s;
}

Vec3f toVec3(py::handle value, const std::string& name) {
  if (!PySequence_Check(value.ptr()) || PyUnicode_Check(value.ptr()) || PySequence_Size(value.ptr()) != 3) {
    PyErr_Clear();
    throw InvalidArgument(name, shown(value), "must be 3 numbers");
  }
  py::sequence s = py::reinterpret_borrow<py::sequence>(value);
  Vec3f v;
  for (int i = 0; i < 3; ++i) v[i] = toFloat(s[i], name + "[" + std::to_string(i) + "]");
  return v;
}

Quat toQuat(py::handle value, const std::string& name) {
  if (!PySequence_Check(value.ptr()) || PyUnicode_Check(value.ptr()) || PySequence_Size(value.ptr()) != 4) {
    PyErr_Clear();
    throw InvalidArgument(name, shown(value), "must be a quaternion of 4 numbers (x, y, z, w)");
  }
  py::sequence s = py::reinterpret_borrow<py::sequence>(value);
  float c[4];
  for (int i = 0; i < 4; ++i) c[i] = toFloat(s[i], name + "[" + std::to_string(i) + "]");
  return {c[3], c[0], c[1], c[2]};
}

std::vector<Vec3f> toPoints(py::handle value, const std::string& name) {
  const py::array_t<float> a = rows3(value, name);
  std::vector<Vec3f> points((size_t)a.shape(0));
  static_assert(sizeof(Vec3f) == 3 * sizeof(float), "Vec3f is three packed floats");
  if (!points.empty()) std::memcpy((void*)points.data(), a.data(), points.size() * sizeof(Vec3f));
  return points;
}

TriangleMesh toMesh(py::handle vertices, py::handle triangles, const std::string& name) {
  TriangleMesh mesh;
  mesh.vertices = toPoints(vertices, name + ".vertices");
  py::array_t<long long, py::array::c_style | py::array::forcecast> t;
  // integers only: a float array cast to indices would hide a mistake
  const bool integral = py::isinstance<py::array>(triangles)
                            ? py::reinterpret_borrow<py::array>(triangles).dtype().kind() == 'i' ||
                                  py::reinterpret_borrow<py::array>(triangles).dtype().kind() == 'u'
                            : true;
  try {
    if (integral) t = py::array_t<long long, py::array::c_style | py::array::forcecast>::ensure(triangles);
  } catch (const py::error_already_set&) {
  }
  PyErr_Clear();
  if (!t || t.ndim() != 2 || t.shape(1) != 3)
    throw InvalidArgument(name + ".triangles", shown(triangles), "must be an integer array of shape (M, 3)");
  const long long n = (long long)mesh.vertices.size();
  mesh.indices.resize((size_t)t.size());
  const long long* idx = t.data();
  for (size_t i = 0; i < mesh.indices.size(); ++i) {
    if (idx[i] < 0 || idx[i] >= n)
      throw InvalidArgument(name + ".triangles[" + std::to_string(i / 3) + "][" + std::to_string(i % 3) + "]",
                            std::to_string(idx[i]), "must name a vertex, 0 to " + std::to_string(n - 1));
    mesh.indices[i] = (uint32_t)idx[i];
  }
  return mesh;
}

nlohmann::json toJson(py::handle value, const std::string& name) {
  using Json = nlohmann::json;
  if (value.is_none()) return nullptr;
  if (PyBool_Check(value.ptr())) return value.cast<bool>();
  if (PyLong_Check(value.ptr())) {
    int overflow = 0;
    const long long v = PyLong_AsLongLongAndOverflow(value.ptr(), &overflow);
    if (overflow) throw InvalidArgument(name, shown(value), "must fit a 64-bit integer");
    return v;
  }
  if (PyFloat_Check(value.ptr())) return value.cast<double>();
  if (PyUnicode_Check(value.ptr())) return value.cast<std::string>();
  if (PyDict_Check(value.ptr())) {
    Json j = Json::object();
    for (auto item : py::reinterpret_borrow<py::dict>(value)) {
      if (!PyUnicode_Check(item.first.ptr())) throw InvalidArgument(name, shown(item.first), "keys must be strings");
      const std::string key = item.first.cast<std::string>();
      j[key] = toJson(item.second, name + "." + key);
    }
    return j;
  }
  if (PyList_Check(value.ptr()) || PyTuple_Check(value.ptr())) {
    Json j = Json::array();
    size_t i = 0;
    for (auto item : py::reinterpret_borrow<py::sequence>(value))
      j.push_back(toJson(item, name + "[" + std::to_string(i++) + "]"));
    return j;
  }
  // numpy arrays and scalars: their Python values
  if (py::hasattr(value, "tolist") && py::hasattr(value, "dtype")) return toJson(value.attr("tolist")(), name);
  throw InvalidArgument(name, shown(value), "must be a dict, list, tuple, number, string, bool or None");
}

// Arrays are made with a shape container only: pybind11 2.10 (Debian's) reads the item size
// from the dtype's struct, whose layout NumPy 2 changed, when it has to compute strides for a
// base py::array; array_t's shape constructors use sizeof(float) instead.
py::array_t<float> array(Vec3f v) { return py::array_t<float>(std::vector<py::ssize_t>{3}, &v.x); }

py::array_t<float> array(Quat q) {
  const float xyzw[4] = {q.x, q.y, q.z, q.w};
  return py::array_t<float>(std::vector<py::ssize_t>{4}, xyzw);
}

py::tuple stateTuple(const ShapeState& s) {
  return py::make_tuple(array(s.pose.position), array(s.pose.rotation), array(s.linearVelocity),
                        array(s.angularVelocity));
}

py::tuple impulseTuple(const ShapeImpulse& i) { return py::make_tuple(array(i.linear), array(i.angular)); }

ShapeState toState(py::handle position, py::handle orientation, py::handle linearVelocity, py::handle angularVelocity) {
  ShapeState s;
  s.pose.position = toVec3(position, "position");
  s.pose.rotation = toQuat(orientation, "orientation");
  s.linearVelocity = toVec3(linearVelocity, "linear_velocity");
  s.angularVelocity = toVec3(angularVelocity, "angular_velocity");
  return s;
}

}  // namespace mpm::python
