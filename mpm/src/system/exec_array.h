#pragma once
// ExecArray<T, Exec>: an owned array in an execution backend's memory space, and the
// element-wise kernels any such array is filled with.
#include <cstddef>
#include <type_traits>
#include <utility>

#include "mpm/math.h"

namespace mpm {

/// Array in an Exec's memory space, owned.
template <class T, class Exec>
class ExecArray {
 public:
  ExecArray() = default;
  ExecArray(const ExecArray&) = delete;
  ExecArray& operator=(const ExecArray&) = delete;
  ~ExecArray() { reset(); }
  void bind(Exec* exec) { exec_ = exec; }
  /// Resizes to exactly n elements; contents are not kept.
  void resizeDiscard(size_t n) {
    if (n == size_) return;
    reset();
    if (n) data_ = exec_->template allocate<T>(n);
    size_ = n;
  }
  /// Grows to at least n elements (never shrinks); contents are not kept.
  void reserveDiscard(size_t n) {
    if (n > size_) resizeDiscard(n);
  }
  void reset() {
    if (data_) exec_->release(data_);
    data_ = nullptr;
    size_ = 0;
  }
  void swap(ExecArray& o) {
    std::swap(data_, o.data_);
    std::swap(size_, o.size_);
  }
  T* data() const { return data_; }
  size_t size() const { return size_; }
  size_t bytes() const { return size_ * sizeof(T); }

 private:
  Exec* exec_ = nullptr;
  T* data_ = nullptr;
  size_t size_ = 0;
};

namespace kernels {

/// data[i] = value.
template <class T>
struct Fill {
  T* data;
  T value;
  MPM_HD void operator()(size_t i) const { data[i] = value; }
};

}  // namespace kernels

template <class Exec, class = void>
struct HasThreadCount : std::false_type {};
template <class Exec>
struct HasThreadCount<Exec, std::void_t<decltype(std::declval<Exec&>().setThreads(1))>> : std::true_type {};

/// Owns a backend's Exec. A solver system derives from it first, ahead of ShapeBackend:
/// base classes are built in order before any member and destroyed in reverse after them,
/// so the Exec exists before the shapes and arrays that bind to it and outlives them.
template <class Exec>
class ExecOwner {
 protected:
  template <class... Args>
  explicit ExecOwner(Args&&... args) : exec_(std::forward<Args>(args)...) {}
  /// Sets the CPU loops' thread count of an Exec that has one (CpuExec); others have no
  /// threads to set.
  void setExecThreads(int threads) {
    if constexpr (HasThreadCount<Exec>::value) exec_.setThreads(threads);
  }
  mutable Exec exec_;
};

}  // namespace mpm
