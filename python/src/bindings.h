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
///
/// Calls that let go of the GIL (step, advance, fetch_results, save, load, a mesh slicer)
/// mark the scene in use (Released): while one runs, another Python thread's call on the
/// same scene is refused with mpm_bullet.Error instead of racing it inside the library.
/// The mark is read and written with the GIL held only.
class PyScene {
 public:
  explicit PyScene(const SceneSettings& settings) : scene_(settings) {}
  /// The scene, for a call that keeps the GIL.
  Scene& scene() {
    refuseWhileInUse();
    return scene_;
  }
  const Scene& scene() const {
    refuseWhileInUse();
    return scene_;
  }
  std::vector<Vec3f> vectors;
  std::vector<Mat3f> matrices;

  /// For mpm_bullet.SceneBatch (batch_bindings.cpp), which marks each of its scenes in use
  /// (with the GIL held) before it lets go of the GIL for the step, and clears the marks after.
  Scene& markInUse(const char* call) {
    if (inUse_) throw StepInProgress(std::string(call) + ": another thread is in a call on one of the batch's scenes");
    inUse_ = true;
    return scene_;
  }
  void clearInUse() { inUse_ = false; }
  /// Scene::cancel, which any thread may call while another is in a call on the scene.
  void cancel() { scene_.cancel(); }

  /// Marks the scene in use, then lets go of the GIL; scene() is the scene within.
  class Released {
   public:
    Released(PyScene& s, const char* call) : s_(s), mark_(s, call), release_() {}
    Scene& scene() { return s_.scene_; }

   private:
    struct Mark {
      Mark(PyScene& s, const char* call) : s(s) {
        if (s.inUse_) throw StepInProgress(std::string("Scene.") + call + ": another thread is in a call on this scene");
        s.inUse_ = true;
      }
      ~Mark() { s.inUse_ = false; }  // after release_ took the GIL back
      PyScene& s;
    };
    PyScene& s_;
    Mark mark_;
    py::gil_scoped_release release_;
  };

 private:
  void refuseWhileInUse() const {
    if (inUse_) throw StepInProgress("mpm_bullet.Scene: another thread is stepping, saving or loading this scene");
  }
  Scene scene_;
  bool inUse_ = false;
};
using SceneClass = py::class_<PyScene>;

void bindErrors(py::module_& m);
void bindHandles(py::module_& m);
void bindScene(py::module_& m, SceneClass& c);
void bindShapes(SceneClass& c);
void bindTools(SceneClass& c);
void bindArrays(SceneClass& c);
void bindBatch(py::module_& m);

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
