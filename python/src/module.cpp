// mpm_bullet._core: the library's scenes in Python (pybind11). The package mpm_bullet
// re-exports these names; python/mpm_bullet/__init__.py.
#include "bindings.h"

PYBIND11_MODULE(_core, m) {
  m.doc() = "MPM soft tissue (mpm_bullet): scenes, objects, shapes, slicers, curves, checkpoints.";
  mpm::python::bindErrors(m);
  mpm::python::bindHandles(m);
  mpm::python::SceneClass scene(m, "Scene", "A simulation world of MPM material (mpm::Scene).");
  mpm::python::bindScene(m, scene);
  mpm::python::bindShapes(scene);
  mpm::python::bindTools(scene);
  mpm::python::bindArrays(scene);
  mpm::python::bindBatch(m);
  m.def("cuda_device_available", &mpm::cudaDeviceAvailable, "True if a CUDA device is usable here.");
}
