// Particle fields as numpy float32 arrays: one bulk copy from the scene's read into a new
// array, or into the caller's array (out=) so a loop reading every step allocates nothing.
#include <pybind11/stl.h>

#include <cstring>

#include "bindings.h"

namespace mpm::python {

namespace {

/// The array to fill: a new one of `shape`, or `out` once it is checked to be one.
py::array target(py::handle out, const std::vector<py::ssize_t>& shape) {
  if (out.is_none()) return py::array_t<float>(shape);
  std::string want = "(";
  for (size_t i = 0; i < shape.size(); ++i) want += (i ? ", " : "") + std::to_string(shape[i]);
  const std::string why = "must be a C-contiguous, writeable float32 numpy array of shape " + want + ")";
  if (!py::isinstance<py::array>(out)) throw InvalidArgument("out", shown(out), why + " (got no numpy array)");
  py::array a = py::reinterpret_borrow<py::array>(out);
  std::string got = py::str(a.dtype()).cast<std::string>() + " (";
  for (py::ssize_t i = 0; i < a.ndim(); ++i) got += (i ? ", " : "") + std::to_string(a.shape(i));
  got += a.ndim() == 1 ? ",)" : ")";
  if (!a.dtype().is(py::dtype::of<float>())) throw InvalidArgument("out", got, why);
  bool same = a.ndim() == (py::ssize_t)shape.size();
  for (size_t i = 0; same && i < shape.size(); ++i) same = a.shape((py::ssize_t)i) == shape[i];
  if (!same) throw InvalidArgument("out", got, why);
  if (!(a.flags() & py::array::c_style)) throw InvalidArgument("out", got + " not C-contiguous", why);
  if (!a.writeable()) throw InvalidArgument("out", got + " read-only", why);
  return a;
}

template <class T>
py::array copied(const std::vector<T>& v, py::handle out, std::vector<py::ssize_t> shape) {
  shape[0] = (py::ssize_t)v.size();
  py::array a = target(out, shape);
  if (!v.empty()) std::memcpy(a.mutable_data(), v.data(), v.size() * sizeof(T));
  return a;
}

}  // namespace

void bindArrays(SceneClass& c) {
  static_assert(sizeof(Vec3f) == 3 * sizeof(float) && sizeof(Mat3f) == 9 * sizeof(float), "packed floats");
  c.def(
      "positions",
      [](PyScene& s, ParticleObjectId id, py::handle out) {
        s.scene().readPositions(id, s.vectors);
        return copied(s.vectors, out, {0, 3});
      },
      py::arg("obj"), py::arg("out") = py::none(),
      "Particle positions [m] of an object, (N, 3) float32; out= fills your array instead.");
  c.def(
      "velocities",
      [](PyScene& s, ParticleObjectId id, py::handle out) {
        s.scene().readVelocities(id, s.vectors);
        return copied(s.vectors, out, {0, 3});
      },
      py::arg("obj"), py::arg("out") = py::none(), "Particle velocities [m/s], (N, 3) float32; out= as positions.");
  c.def(
      "deformation_gradients",
      [](PyScene& s, ParticleObjectId id, py::handle out) {
        s.scene().readDeformationGradients(id, s.matrices);
        return copied(s.matrices, out, {0, 3, 3});
      },
      py::arg("obj"), py::arg("out") = py::none(),
      "Deformation gradients F, (N, 3, 3) float32, F[n][i][j]; out= as positions.");
}

}  // namespace mpm::python
