// mpm_bullet.SceneBatch: many scenes advanced together (mpm/scene_batch.h). The batch keeps
// its Python scenes alive and marks each in use while it steps them without the GIL, so
// another thread's call on one of them is refused instead of racing the step.
#include <pybind11/stl.h>

#include <memory>
#include <vector>

#include "bindings.h"
#include "mpm/scene_batch.h"

namespace mpm::python {

namespace {

class PyBatch {
 public:
  PyBatch(py::list scenes, int threads) {
    std::vector<Scene*> list;
    for (size_t i = 0; i < scenes.size(); ++i) {
      py::handle item = scenes[i];
      if (item.is_none() || !py::isinstance<PyScene>(item))
        throw InvalidArgument("SceneBatch scenes[" + std::to_string(i) + "]", shown(item), "must be an mpm_bullet.Scene");
      PyScene& s = item.cast<PyScene&>();
      scenes_.push_back(&s);
      list.push_back(&s.scene());
      keep_.append(item);
    }
    batch_ = std::make_unique<SceneBatch>(std::move(list), threads);
  }

  std::vector<StepReport> step(py::object dt) {
    std::vector<float> dts;
    if (py::isinstance<py::sequence>(dt))
      dts = dt.cast<std::vector<float>>();  // one per scene: the batch checks the count
    else
      dts.assign(scenes_.size(), dt.cast<float>());
    size_t marked = 0;
    struct Unmark {  // clears the marks set so far, whatever happens
      std::vector<PyScene*>& scenes;
      size_t& marked;
      ~Unmark() {
        for (size_t i = 0; i < marked; ++i) scenes[i]->clearInUse();
      }
    } unmark{scenes_, marked};
    for (; marked < scenes_.size(); ++marked) scenes_[marked]->markInUse("SceneBatch.step");
    py::gil_scoped_release release;
    batch_->advance(dts);
    return batch_->fetchResults();
  }

  size_t size() const { return scenes_.size(); }
  int threads() const { return batch_->threads(); }
  std::vector<size_t> failed() const { return batch_->failedScenes(); }

 private:
  std::vector<PyScene*> scenes_;
  py::list keep_;  // the Python scenes, alive as long as the batch
  std::unique_ptr<SceneBatch> batch_;
};

}  // namespace

void bindBatch(py::module_& m) {
  py::class_<PyBatch>(m, "SceneBatch",
                      "Scenes advanced together (mpm::SceneBatch): on the CPU each scene runs on one of the "
                      "batch's threads and ends bit for bit where it would have stepped alone.")
      .def(py::init<py::list, int>(), py::arg("scenes"), py::arg("threads") = 0,
           "SceneBatch(scenes: list of Scene, threads=0): threads 0 = all hardware threads.")
      .def("step", &PyBatch::step, py::arg("dt"),
           "Advances every scene by dt [s] (a number, or one per scene) and waits; returns their "
           "StepReports. A scene's error is raised after all finished (failed_scenes lists them).")
      .def("__len__", &PyBatch::size)
      .def_property_readonly("threads", &PyBatch::threads)
      .def_property_readonly("failed_scenes", &PyBatch::failed, "Scenes whose last step failed.");
}

}  // namespace mpm::python
