// The library's errors as Python exceptions with the same message:
//   Error (RuntimeError)                  every mpm::Error not named below
//   InvalidArgument (Error, ValueError)   .field and .value as the C++ exception has them
//   CheckpointError (Error)               .reason, e.g. "Checksum"
//   SimulationDiverged, BackendUnavailable, StepInProgress, AdvanceCancelled (Error)
//   OutOfMemory (Error, MemoryError)      .allocation and .bytes as the C++ exception has them
#include "bindings.h"

namespace mpm::python {

namespace {

PyObject* newException(py::module_& m, const char* name, PyObject* bases, const char* doc) {
  const std::string full = std::string("mpm_bullet.") + name;
  PyObject* type = PyErr_NewExceptionWithDoc(full.c_str(), doc, bases, nullptr);
  if (!type) throw py::error_already_set();
  m.add_object(name, py::handle(type));  // the module keeps the reference
  return type;
}

/// Raises `type` with `message` and the given attributes set on the exception.
void raise(PyObject* type, const char* message, std::initializer_list<std::pair<const char*, std::string>> attrs) {
  py::object e = py::reinterpret_borrow<py::object>(type)(message);
  for (const auto& [name, value] : attrs) e.attr(name) = value;
  PyErr_SetObject(type, e.ptr());
}

const char* reasonName(CheckpointError::Reason r) {
  switch (r) {
    case CheckpointError::Reason::Io: return "Io";
    case CheckpointError::Reason::NotACheckpoint: return "NotACheckpoint";
    case CheckpointError::Reason::Version: return "Version";
    case CheckpointError::Reason::Truncated: return "Truncated";
    case CheckpointError::Reason::Checksum: return "Checksum";
    case CheckpointError::Reason::OtherScene: return "OtherScene";
    case CheckpointError::Reason::Unsupported: return "Unsupported";
    case CheckpointError::Reason::Malformed: return "Malformed";
  }
  return "?";
}

}  // namespace

void bindErrors(py::module_& m) {
  static PyObject* error = newException(m, "Error", PyExc_RuntimeError, "Base of every error the library raises.");
  py::tuple invalidBases = py::make_tuple(py::handle(error), py::handle(PyExc_ValueError));
  static PyObject* invalid = newException(m, "InvalidArgument", invalidBases.ptr(),
                                          "A value the library cannot accept; .field names it, .value shows it.");
  static PyObject* checkpoint = newException(m, "CheckpointError", error,
                                             "A checkpoint could not be written or was refused; .reason says why.");
  static PyObject* diverged = newException(m, "SimulationDiverged", error,
                                           "A step produced a non-finite state; the scene is as before it.");
  static PyObject* backend = newException(m, "BackendUnavailable", error, "The backend asked for cannot run here.");
  static PyObject* busy = newException(m, "StepInProgress", error,
                                       "An advance is running: nothing was read or changed; call again after it.");
  static PyObject* cancelled = newException(m, "AdvanceCancelled", error,
                                            "cancel() stopped the advance; the scene is as before it.");
  py::tuple memoryBases = py::make_tuple(py::handle(error), py::handle(PyExc_MemoryError));
  static PyObject* memory = newException(m, "OutOfMemory", memoryBases.ptr(),
                                         "Memory ran out; .allocation says for what, .bytes how much (0: unknown). "
                                         "The scene is as before the call.");
  py::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const InvalidArgument& e) {
      raise(invalid, e.what(), {{"field", e.field()}, {"value", e.value()}});
    } catch (const CheckpointError& e) {
      raise(checkpoint, e.what(), {{"reason", reasonName(e.reason())}});
    } catch (const SimulationDiverged& e) {
      PyErr_SetString(diverged, e.what());
    } catch (const BackendUnavailable& e) {
      PyErr_SetString(backend, e.what());
    } catch (const StepInProgress& e) {
      PyErr_SetString(busy, e.what());
    } catch (const AdvanceCancelled& e) {
      PyErr_SetString(cancelled, e.what());
    } catch (const OutOfMemory& e) {
      raise(memory, e.what(), {{"allocation", e.allocation()}, {"bytes", std::to_string(e.bytes())}});
    } catch (const Error& e) {
      PyErr_SetString(error, e.what());
    }
  });
}

}  // namespace mpm::python
