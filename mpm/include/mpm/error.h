#pragma once
/// Errors reported to the caller. Every public entry point validates its input before it
/// changes anything, so a rejected call leaves the scene exactly as it was.
#include <cstddef>
#include <stdexcept>
#include <string>

namespace mpm {

/// Base of every error the library throws.
class Error : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// A public call got a value it cannot accept. `field()` names the offending field
/// (e.g. "SceneSettings.dx"), `value()` is the value as text.
class InvalidArgument : public Error {
 public:
  InvalidArgument(std::string field, std::string value, const std::string& why)
      : Error(field + " = " + value + ": " + why), field_(std::move(field)), value_(std::move(value)) {}
  const std::string& field() const { return field_; }
  const std::string& value() const { return value_; }

 private:
  std::string field_, value_;
};

/// The requested backend cannot run here (e.g. CUDA asked for, no device present).
class BackendUnavailable : public Error {
 public:
  using Error::Error;
};

/// A step produced a non-finite state, lost particles or (with SceneSettings::energyCheck)
/// gained energy from nowhere; names the object and particle.
class SimulationDiverged : public Error {
 public:
  using Error::Error;
};

/// Memory ran out: `allocation()` says what was being allocated, `bytes()` how much (0 when
/// the allocator did not say). Thrown by a call or an advance, on whichever thread ran out;
/// the scene is as it was before the call (an advance: before that advance) and steps on
/// once memory allows.
class OutOfMemory : public Error {
 public:
  OutOfMemory(std::string allocation, size_t bytes)
      : Error("out of memory: " + allocation +
              (bytes ? " (" + std::to_string(bytes) + " bytes)" : std::string(" (size not known)"))),
        allocation_(std::move(allocation)),
        bytes_(bytes) {}
  const std::string& allocation() const { return allocation_; }
  size_t bytes() const { return bytes_; }

 private:
  std::string allocation_;
  size_t bytes_;
};

/// A call that reads or changes what a step writes was made, from any thread, while an
/// advance runs (between advance() and the return of fetchResults(), or inside step()).
/// Nothing was read or changed; call again after fetchResults().
class StepInProgress : public Error {
 public:
  using Error::Error;
};

/// Scene::cancel() stopped the advance at a substep boundary; the scene is as it was
/// before that advance.
class AdvanceCancelled : public Error {
 public:
  using Error::Error;
};

/// A checkpoint could not be written or was refused on loading; `reason()` says which
/// check failed. The scene is unchanged either way.
class CheckpointError : public Error {
 public:
  enum class Reason {
    Io,          ///< the file could not be opened, written, flushed or renamed
    NotACheckpoint,  ///< wrong magic bytes
    Version,     ///< written by another format version
    Truncated,   ///< shorter than its header or a section says
    Checksum,    ///< the payload's CRC-32 does not match: corrupted
    OtherScene,  ///< a checkpoint of a scene with different model settings
    Unsupported, ///< valid, but this scene cannot take it (named in the message)
    Malformed    ///< the checksum holds, but a value cannot have been written here (a bool of 29)
  };
  CheckpointError(Reason reason, const std::string& what) : Error("checkpoint: " + what), reason_(reason) {}
  Reason reason() const { return reason_; }

 private:
  Reason reason_;
};

}  // namespace mpm
