#pragma once
// Shared by the binding files of mpm_bullet._core: the Python Scene and the conversions
// between Python values and the library's types. Each *_bindings.cpp adds one topic's
// methods to the Scene class.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <nlohmann/json.hpp>

#include <string>
#include <vector>

#include "mpm/scene.h"

namespace py = pybind11;

namespace mpm::python {

/// The scene behind mpm_bullet.Scene, with the buffers the array reads go through (kept,
/// so reading every step allocates nothing once they have grown).
struct PyScene {
  explicit PyScene(const SceneSettings& settings) : scene(settings) {}
  Scene scene;
  std::vector<Vec3f> vectors;
  std::vector<Mat3f> matrices;
};
using SceneClass = py::class_<PyScene>;

void bindErrors(py::module_& m);
void bindHandles(py::module_& m);
void bindScene(py::module_& m, SceneClass& c);
void bindShapes(SceneClass& c);
void bindTools(SceneClass& c);
void bindArrays(SceneClass& c);

// --- conversions (convert.cpp); a value that does not convert throws InvalidArgument naming `name`

/// Python's repr of a value, cut short, for error messages.
std::string shown(py::handle value);
Vec3f toVec3(py::handle value, const std::string& name);
/// A quaternion in pybullet's order (x, y, z, w) to the library's Quat (w first). Not
/// normalised: the library refuses one that is not a unit quaternion.
Quat toQuat(py::handle value, const std::string& name);
std::vector<Vec3f> toPoints(py::handle value, const std::string& name);
/// Vertices (N, 3) and triangles (M, 3) of integers to a mesh, the indices checked.
TriangleMesh toMesh(py::handle vertices, py::handle triangles, const std::string& name);
/// A dict (lists, numbers, strings, bools, numpy arrays and scalars) as JSON, for the scene
/// file's readers.
nlohmann::json toJson(py::handle value, const std::string& name);

py::array_t<float> array(Vec3f v);
/// (x, y, z, w)
py::array_t<float> array(Quat q);
/// (position, orientation, linear velocity, angular velocity)
py::tuple stateTuple(const ShapeState& s);
/// (linear, angular)
py::tuple impulseTuple(const ShapeImpulse& i);
ShapeState toState(py::handle position, py::handle orientation, py::handle linearVelocity,
                   py::handle angularVelocity);

}  // namespace mpm::python
