#pragma once
// ShapeSet<Exec>: the rigid shapes as a backend holds them (bodies, their parts, cached mesh
// distance grids) and the momentum each body received, in Exec memory. Shared by every
// solver system: the particle-grid solvers and MTLED differ in where the contact is
// applied (grid nodes or meshless nodes), not in how shapes are stored, placed and moved.
#include <cmath>
#include <map>
#include <memory>
#include <vector>

#include "system/exec_array.h"
#include "system/sim_backend.h"
#include "contact/contact_law.h"
#include "contact/push_out.h"

namespace mpm {

namespace kernels {

struct PlaceParts {
  PartView* parts;
  const BodyView* bodies;
  float margin, touchReach;
  MPM_HD void operator()(size_t i) const { placePart(parts[i], bodies[parts[i].body], margin, touchReach); }
};

struct StartBodyExchange {
  BodyView* bodies;
  float dt, gravityDt;
  MPM_HD void operator()(size_t i) const { startBodyExchange(bodies[i], dt, gravityDt); }
};

struct PredictBodies {
  BodyView* bodies;
  const ContactSums* sums;
  MPM_HD void operator()(size_t i) const { predictBodyVelocity(bodies[i], sums[i]); }
};

struct SettleBodies {
  BodyView* bodies;
  const ContactSums* sums;
  /// momentum exchanged, summed over the substeps of an advance; `mass`: the time integral
  /// of the applying pass's contact mass [kg s] (a needle's tip inside adds the material's
  /// presence ahead of it to its own body's, ParticleGridSystem::takeImpulses)
  ContactSums* record;
  MPM_HD void operator()(size_t i) const {
    const Vec3f H = settleBodyVelocity(bodies[i], sums[i]);
    for (int k = 0; k < 3; ++k) record[i].impulse[k] += sums[i].impulse[k];
    record[i].mass += sums[i].mass * bodies[i].substepDt;
    record[i].angular[0] += H.x;
    record[i].angular[1] += H.y;
    record[i].angular[2] += H.z;
  }
};

struct MoveBodies {
  BodyView* bodies;
  float dt;
  MPM_HD void operator()(size_t i) const { moveBody(bodies[i], dt); }
};

}  // namespace kernels

template <class Exec>
class ShapeSet {
 public:
  explicit ShapeSet(Exec& exec) : exec_(exec) {
    bodies_.bind(&exec_);
    parts_.bind(&exec_);
    stepSums_.bind(&exec_);
    record_.bind(&exec_);
  }

  BodyView* bodies() const { return bodies_.data(); }
  int bodyCount() const { return (int)bodies_.size(); }
  const PartView* parts() const { return parts_.data(); }
  int partCount() const { return (int)parts_.size(); }
  /// Per-body sums of the current contact pass.
  ContactSums* stepSums() const { return stepSums_.data(); }
  bool anyDynamic() const { return anyDynamic_; }

  void set(const std::vector<BodyView>& bodies, const std::vector<PartView>& parts) {
    bodies_.resizeDiscard(bodies.size());
    exec_.copyToDevice(bodies_.data(), bodies.data(), bodies.size() * sizeof(BodyView));
    parts_.resizeDiscard(parts.size());
    exec_.copyToDevice(parts_.data(), parts.data(), parts.size() * sizeof(PartView));
    stepSums_.resizeDiscard(bodies.size());
    // the impulse record restarts with the new shape list
    std::vector<ContactSums> zero(bodies.size(), ContactSums{});
    record_.resizeDiscard(bodies.size());
    exec_.copyToDevice(record_.data(), zero.data(), zero.size() * sizeof(ContactSums));
    anyDynamic_ = anyCurve_ = false;
    for (const BodyView& b : bodies) {
      anyDynamic_ = anyDynamic_ || b.dynamic;
      anyCurve_ = anyCurve_ || b.mode == kContactCurve;  // a needle's shaft friction needs the substep
    }
  }

  /// Places the parts at their bodies' poses, bounds grown by `margin` and the band, the
  /// particles' push-out boxes by `touchReach` (placePart; infinite: the bounds).
  void place(float margin, float touchReach = INFINITY) {
    if (parts_.size() == 0) return;
    exec_.forEach(parts_.size(), kernels::PlaceParts{parts_.data(), bodies_.data(), margin, touchReach});
  }
  /// The momentum exchange of a substep with the material (contact/rigid_body.h): the dynamic bodies'
  /// gravity (`gravityDt`, 0 for none), their velocities predicted from measuring passes,
  /// then the applying pass and the bodies' velocities from what they received.
  /// `contactPass(pass)` runs one contact pass over the material's nodes into stepSums().
  template <class ContactPass>
  void exchange(float dt, float gravityDt, ContactPass&& contactPass) {
    if (anyDynamic_ || anyCurve_) exec_.forEach(bodies_.size(), kernels::StartBodyExchange{bodies_.data(), dt, gravityDt});
    if (anyDynamic_) {
      for (int k = 0; k < kBodyPredictionSteps; ++k) {
        contactPass(0);
        exec_.forEach(bodies_.size(), kernels::PredictBodies{bodies_.data(), stepSums_.data()});
      }
    }
    contactPass(1);
    exec_.forEach(bodies_.size(), kernels::SettleBodies{bodies_.data(), stepSums_.data(), record_.data()});
  }
  /// Advances the bodies' poses over a substep.
  void move(float dt) {
    if (bodies_.size() == 0) return;
    exec_.forEach(bodies_.size(), kernels::MoveBodies{bodies_.data(), dt});
  }

  /// Device copy of a mesh grid's values. The entry holds the grid itself: keyed by the
  /// grid's address alone, a grid allocated where a freed one had been would get the freed
  /// one's values (and read past them if it is larger).
  const float* meshValues(const std::shared_ptr<const SignedDistanceGrid>& grid) {
    MeshCopy& slot = meshes_[grid.get()];
    if (!slot.values) {
      slot.grid = grid;
      slot.values = std::make_unique<ExecArray<float, Exec>>();
      slot.values->bind(&exec_);
      slot.values->resizeDiscard(grid->values.size());
      exec_.copyToDevice(slot.values->data(), grid->values.data(), grid->values.size() * sizeof(float));
    }
    return slot.values->data();
  }

  /// Drops the copies (and the grids they hold) of meshes no live shape uses.
  void releaseMeshesExcept(const std::vector<const SignedDistanceGrid*>& live) {
    for (auto it = meshes_.begin(); it != meshes_.end();) {
      bool keep = false;
      for (const auto* l : live) keep = keep || l == it->first;
      it = keep ? std::next(it) : meshes_.erase(it);
    }
  }

  void readBodies(std::vector<BodyView>& out) const {
    out.resize(bodies_.size());
    exec_.copyToHost(out.data(), bodies_.data(), out.size() * sizeof(BodyView));
  }

  std::vector<ContactSums> takeImpulses() {
    std::vector<ContactSums> out(record_.size()), zero(record_.size(), ContactSums{});
    exec_.copyToHost(out.data(), record_.data(), out.size() * sizeof(ContactSums));
    exec_.copyToDevice(record_.data(), zero.data(), zero.size() * sizeof(ContactSums));
    return out;
  }

  size_t memoryBytes() const {
    size_t b = bodies_.bytes() + parts_.bytes() + stepSums_.bytes() + record_.bytes();
    for (const auto& m : meshes_) b += m.second.values->bytes();
    return b;
  }

 private:
  Exec& exec_;
  ExecArray<BodyView, Exec> bodies_;
  ExecArray<PartView, Exec> parts_;
  ExecArray<ContactSums, Exec> stepSums_, record_;
  bool anyDynamic_ = false;
  bool anyCurve_ = false;  ///< a curve's body (kContactCurve) is among them
  struct MeshCopy {
    std::shared_ptr<const SignedDistanceGrid> grid;  ///< kept alive: its address stays its own
    std::unique_ptr<ExecArray<float, Exec>> values;
  };
  std::map<const SignedDistanceGrid*, MeshCopy> meshes_;
};

/// A backend that holds rigid shapes: the SimBackend shape calls, answered by its ShapeSet
/// once for every solver.
template <class Exec>
class ShapeBackend : public SimBackend {
 public:
  void setShapes(const std::vector<BodyView>& bodies, const std::vector<PartView>& parts) override {
    shapes_.set(bodies, parts);
  }
  const float* meshValues(const std::shared_ptr<const SignedDistanceGrid>& grid) override {
    return shapes_.meshValues(grid);
  }
  void releaseMeshesExcept(const std::vector<const SignedDistanceGrid*>& live) override {
    shapes_.releaseMeshesExcept(live);
  }
  void readBodies(std::vector<BodyView>& out) const override { shapes_.readBodies(out); }
  std::vector<ContactSums> takeImpulses() override { return shapes_.takeImpulses(); }

 protected:
  /// `exec` must outlive the shapes (the solver systems hold it in ExecOwner, a base
  /// constructed before this one).
  explicit ShapeBackend(Exec& exec) : shapes_(exec) {}
  ShapeSet<Exec> shapes_;
};

}  // namespace mpm
