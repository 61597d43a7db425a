// Scene, settings, particle objects, stepping and checkpoints. Settings and object dicts are
// read by the scene files' own readers (bullet_bridge/src/scene_file/entry_readers.h), so a
// dict is refused with the message a file would get ("settings.dx = -1: must be > 0").
#include <pybind11/stl.h>

#include "bindings.h"
#include "scene_file/entry_readers.h"

namespace mpm::python {

namespace {

std::vector<uint8_t> toBytes(const py::bytes& b) {
  const std::string_view s(b);
  return {s.begin(), s.end()};
}
py::bytes fromBytes(const std::vector<uint8_t>& v) { return py::bytes((const char*)v.data(), v.size()); }

const char* backendName(Backend b) {
  switch (b) {
    case Backend::Auto: return "Auto";
    case Backend::Cpu: return "Cpu";
    case Backend::Cuda: return "Cuda";
  }
  return "?";
}

py::dict summaryDict(const ObjectSummary& s) {
  py::dict d;
  d["particles"] = s.particles;
  d["mass"] = s.mass;
  d["center_of_mass"] = py::make_tuple(s.centerOfMass[0], s.centerOfMass[1], s.centerOfMass[2]);
  d["momentum"] = py::make_tuple(s.momentum[0], s.momentum[1], s.momentum[2]);
  d["angular_momentum"] = py::make_tuple(s.angularMomentum[0], s.angularMomentum[1], s.angularMomentum[2]);
  d["kinetic_energy"] = s.kineticEnergy;
  return d;
}

}  // namespace

template <class Id>
void bindHandle(py::module_& m, const char* name, const char* doc) {
  py::class_<Id>(m, name, doc)
      .def_readonly("index", &Id::index)
      .def_readonly("generation", &Id::generation)
      .def("__eq__", [](const Id& a, const Id& b) { return a.index == b.index && a.generation == b.generation; })
      .def("__hash__", [](const Id& a) { return py::hash(py::make_tuple(a.index, a.generation)); })
      .def("__repr__", [name](const Id& a) {
        return std::string(name) + "(" + std::to_string(a.index) + ", " + std::to_string(a.generation) + ")";
      });
}

void bindHandles(py::module_& m) {
  bindHandle<ParticleObjectId>(m, "ObjectId", "Handle of a particle object; stale once it is removed.");
  bindHandle<ShapeId>(m, "ShapeId", "Handle of a rigid shape.");
  bindHandle<SlicerId>(m, "SlicerId", "Handle of a slicer (blade).");
  bindHandle<CurveId>(m, "CurveId", "Handle of a curve (needle or thread).");

  py::class_<EnergyBalance>(m, "EnergyBalance", "The particles' energy account [J] (settings energyCheck).")
      .def_readonly("kinetic", &EnergyBalance::kinetic)
      .def_readonly("strain", &EnergyBalance::strain)
      .def_readonly("released", &EnergyBalance::released)
      .def_readonly("start", &EnergyBalance::start)
      .def_readonly("work", &EnergyBalance::work)
      .def_readonly("supplied", &EnergyBalance::supplied)
      .def_property_readonly("excess", &EnergyBalance::excess);
  py::class_<StepReport>(m, "StepReport", "What the last advance did.")
      .def_readonly("substeps", &StepReport::substeps)
      .def_readonly("substep_dt", &StepReport::substepDt)
      .def_readonly("active_blocks", &StepReport::activeBlocks)
      .def_readonly("halvings", &StepReport::halvings)
      .def_readonly("energy", &StepReport::energy)
      .def("__repr__", [](const StepReport& r) {
        return "StepReport(substeps=" + std::to_string(r.substeps) + ", substep_dt=" + std::to_string(r.substepDt) +
               ", active_blocks=" + std::to_string(r.activeBlocks) + ", halvings=" + std::to_string(r.halvings) + ")";
      });
}

void bindScene(py::module_&, SceneClass& c) {
  namespace sf = mpm::bullet::scene_file;
  c.def(py::init([](py::object dict) {
          const nlohmann::json j = dict.is_none() ? nlohmann::json::object() : toJson(dict, "settings");
          const SceneSettings settings = sf::readSettings(&j);
          try {
            return std::make_unique<PyScene>(settings);
          } catch (const InvalidArgument& e) {
            sf::rethrowAt(e, "SceneSettings", "settings");  // as a scene file names it
          }
        }),
        py::arg("settings") = py::none(),
        "Scene(settings: dict): the scene file's \"settings\" object (assets/scenes/scene.schema.json).");

  c.def_property_readonly("time", [](const PyScene& s) { return s.scene().time(); }, "Simulated time [s].");
  c.def_property_readonly("backend", [](const PyScene& s) { return backendName(s.scene().backend()); });
  c.def_property_readonly("dx", [](const PyScene& s) { return s.scene().settings().dx; }, "Grid cell size [m].");
  c.def_property_readonly("gravity", [](const PyScene& s) { return array(s.scene().settings().gravity); });
  c.def("memory_bytes", [](const PyScene& s) { return s.scene().memoryBytes(); });
  c.def("max_substep", [](PyScene& s) { return s.scene().maxSubstep(); }, "Longest substep allowed now [s].");

  // objects
  c.def(
      "add_object",
      [](PyScene& s, py::dict desc) {
        const nlohmann::json j = toJson(desc, "object");
        const sf::ObjectEntry e = sf::readObjectEntry(j, "object", ".", s.scene().settings().dx);
        return sf::addObjectAt(s.scene(), e.desc, "object");
      },
      py::arg("desc"),
      "Adds tissue from a scene file's objects[] entry (primitive, center, halfExtents, radius, "
      "material, ...; a mesh file is relative to the working directory). Returns its ObjectId.");
  c.def("remove_object", [](PyScene& s, ParticleObjectId id) { s.scene().removeParticleObject(id); }, py::arg("obj"));
  c.def("objects", [](const PyScene& s) { return s.scene().particleObjects(); }, "Live objects, in slot order.");
  c.def("is_valid", [](const PyScene& s, ParticleObjectId id) { return s.scene().isValid(id); }, py::arg("obj"));
  c.def("is_valid", [](const PyScene& s, ShapeId id) { return s.scene().isValid(id); }, py::arg("shape"));
  c.def("is_valid", [](const PyScene& s, SlicerId id) { return s.scene().isValid(id); }, py::arg("slicer"));
  c.def("is_valid", [](const PyScene& s, CurveId id) { return s.scene().isValid(id); }, py::arg("curve"));
  c.def(
      "particle_count",
      [](const PyScene& s, std::optional<ParticleObjectId> id) {
        return id ? s.scene().particleCount(*id) : s.scene().particleCount();
      },
      py::arg("obj") = py::none(), "Live particles in the scene, or in one object.");
  c.def("summary", [](const PyScene& s, ParticleObjectId id) { return summaryDict(s.scene().summary(id)); },
        py::arg("obj"), "Mass [kg], center_of_mass [m], momentum, angular_momentum, kinetic_energy of an object.");

  // stepping: the GIL is released while the solver runs
  c.def("step", [](PyScene& s, float dt) { return PyScene::Released(s, "step").scene().step(dt); }, py::arg("dt"),
        "advance(dt) then fetch_results(); returns a StepReport.");
  c.def("advance", [](PyScene& s, float dt) { PyScene::Released(s, "advance").scene().advance(dt); }, py::arg("dt"),
        "Starts advancing by dt [s] on the scene's worker; change nothing until fetch_results().");
  c.def("fetch_results", [](PyScene& s) { return PyScene::Released(s, "fetch_results").scene().fetchResults(); },
        "Waits for the advance; raises its error.");
  c.def("cancel", [](PyScene& s) { s.cancel(); },
        "Stops the running advance (from any thread) at its next substep boundary: its fetch_results() or "
        "step() raises AdvanceCancelled and the scene is as before that advance. Does nothing when none runs.");

  // checkpoints
  c.def(
      "save", [](PyScene& s, const std::string& path, py::bytes attachment) {
        const std::vector<uint8_t> a = toBytes(attachment);
        PyScene::Released(s, "save").scene().save(path, a);
      },
      py::arg("path"), py::arg("attachment") = py::bytes(), "Writes the whole scene to a file (with your attachment).");
  c.def(
      "load", [](PyScene& s, const std::string& path) {
        const std::vector<uint8_t> a = PyScene::Released(s, "load").scene().load(path);
        return fromBytes(a);
      },
      py::arg("path"), "Replaces the scene's state with a file's; returns its attachment.");
  c.def(
      "save_bytes", [](const PyScene& s, py::bytes attachment) { return fromBytes(s.scene().saveToMemory(toBytes(attachment))); },
      py::arg("attachment") = py::bytes(), "The checkpoint as bytes.");
  c.def(
      "load_bytes", [](PyScene& s, py::bytes checkpoint) { return fromBytes(s.scene().loadFromMemory(toBytes(checkpoint))); },
      py::arg("checkpoint"), "Replaces the scene's state with a checkpoint's; returns its attachment.");
  c.def(
      "attachment_of", [](const PyScene& s, py::bytes checkpoint) { return fromBytes(s.scene().attachmentOf(toBytes(checkpoint))); },
      py::arg("checkpoint"), "The attachment of a checkpoint, checked as load_bytes checks it, not loaded.");

  c.def("timings", [](const PyScene& s) {
    const StageTimings t = s.scene().timings();
    py::dict d;
    d["sort"] = t.sort, d["p2g"] = t.p2g, d["grid_update"] = t.gridUpdate, d["contact"] = t.contact, d["g2p"] = t.g2p;
    d["substeps"] = t.substeps;
    return d;
  }, "Seconds per named stage since reset_timings().");
  c.def("reset_timings", [](PyScene& s) { s.scene().resetTimings(); });
}

}  // namespace mpm::python
