#pragma once
// CuttingStage<Exec>: the tools' stage of a particle-grid substep. It records on the
// particles the cuts of the blades beside them (the cut planes the transfers then respect,
// transfer/cut.h) and exchanges the material's resistance to being opened (blades' and
// needles' tips: fracture toughness) between the particles and the tools. A solver system
// holds one and its Method composes it (recordCuts before P2G); a scene without a blade or
// a needle pays one test a substep.
#include <vector>

#include "system/exec_array.h"
#include "system/sim_backend.h"
#include "tools/needle.h"

namespace mpm {

namespace kernels {

/// A part RecordCuts visits (a blade, a curved blade, a needle's tip inside the material)
/// and its slot among the resisting parts (BladeImpulse): the other parts (a thread's segments, the ground) cut nothing, and a suturing scene's
/// particles had tested every one of them each substep.
struct Cutter {
  int part;
  int blade;
};

/// Records on every particle beside a blade the cut it lies in, and with `impulses`
/// (materials with toughness) exchanges the resistance to cutting over the substep between
/// the particle and each blade: the blade's share summed per particle and blade in
/// `impulses`, the particle's in `push`, which P2G hands to the grid (transfer/cut.h).
struct RecordCuts {
  ParticleView P;
  const PartView* parts;
  const Cutter* cutters;  ///< the parts that cut or resist, in part order
  int nCutters;
  const BodyView* bodies;
  const MaterialParams* materials;
  BladeImpulse* impulses;  ///< [blade * P.count + particle]; null: no toughness in the scene
  Vec3f* push;             ///< [particle], with `impulses`
  GridGeometry geo;
  float dt;
  MPM_HD void operator()(size_t i) const {
    const float dx = geo.dx;
    if (push) push[i] = Vec3f{0.f, 0.f, 0.f};
    for (int c = 0; c < nCutters; ++c) {
      const PartView& part = parts[cutters[c].part];
      const int blade = cutters[c].blade;
      if (part.type == kPartCurvedBlade) {
        if (!part.mayTouch(P.x[i], P.x[i])) continue;
        recordCurvedCut(P.cut[i], P.x[i], part, geo);
        const float gc = impulses ? materials[P.object[i]].toughness : 0.f;
        if (gc > 0.f)
          exchange(i, blade, part,
                   curvedCuttingResistance(part, bodies[part.body], P.x[i], P.volume0[i] * determinant(P.F[i]), gc, dx));
        continue;
      }
      if (part.type == kPartTipInside) {
        // the material's presence ahead of the tip is counted without toughness too
        const float gc = materials[P.object[i]].toughness;
        if (impulses && part.mayTouch(P.x[i], P.x[i])) {
          float presence;
          exchange(i, blade, part,
                   needleTipResistance(part, bodies[part.body], P.x[i], P.volume0[i] * determinant(P.F[i]), gc, dx,
                                       presence));
          impulses[(size_t)blade * P.count + i].presence += dt * presence;
        }
        continue;
      }
      if (part.type != kPartBlade) continue;
      if (part.mayTouch(P.x[i], P.x[i])) {
        recordCut(P.cut[i], P.x[i], part, dx);
        const float gc = impulses ? materials[P.object[i]].toughness : 0.f;
        if (gc > 0.f)
          exchange(i, blade, part,
                   cuttingResistance(part, bodies[part.body], P.x[i], P.volume0[i] * determinant(P.F[i]), gc, dx));
      }
    }
  }
  /// The blade's share of force f [N] over the substep in its impulse, the particle's in
  /// its push.
  MPM_HD void exchange(size_t i, int blade, const PartView& part, Vec3f f) const {
    push[i] -= dt * f;
    BladeImpulse& J = impulses[(size_t)blade * P.count + i];
    J.linear += dt * f;
    J.angular += dt * cross(P.x[i] - bodies[part.body].com, f);
  }
};

}  // namespace kernels

template <class Exec>
class CuttingStage {
 public:
  /// `exec` must outlive the stage (the solver system's ExecOwner).
  explicit CuttingStage(Exec& exec) : exec_(exec) {
    bladeImpulses_.bind(&exec_);
    cutters_.bind(&exec_);
    push_.bind(&exec_);
  }

  /// Whether some material resists cutting (MaterialParams::toughness); before setParts.
  void setMaterials(const std::vector<MaterialParams>& m) {
    toughness_ = false;
    for (const MaterialParams& p : m) toughness_ = toughness_ || p.toughness > 0.f;
  }

  /// The tools among the parts of this advance, and their resistances zeroed for
  /// `particles` particles.
  void setParts(const std::vector<PartView>& parts, size_t particles) {
    bladeBodies_.clear();
    std::vector<kernels::Cutter> cutters;
    blades_ = tips_ = false;
    for (size_t i = 0; i < parts.size(); ++i) {
      const PartView& p = parts[i];
      // the resistance to cutting (quad and curved blades) and to a needle's tip
      if (p.type == kPartBlade || p.type == kPartCurvedBlade || p.type == kPartTipInside) {
        cutters.push_back({(int)i, (int)bladeBodies_.size()});
        bladeBodies_.push_back(p.body);
      }
      blades_ = blades_ || isBlade(p.type);
      tips_ = tips_ || p.type == kPartTipInside;
    }
    cutters_.resizeDiscard(cutters.size());
    exec_.copyToDevice(cutters_.data(), cutters.data(), cutters.size() * sizeof(kernels::Cutter));
    everCut_ = everCut_ || blades_;
    // the resistance to cutting and to needles' tips, per particle and blade, summed over
    // the advance
    const size_t n = toughness_ || tips_ ? bladeBodies_.size() * particles : 0;
    bladeImpulses_.resizeDiscard(n);
    push_.resizeDiscard(n ? particles : 0);
    exec_.forEach(n, kernels::Fill<BladeImpulse>{bladeImpulses_.data(), BladeImpulse{}});
  }

  /// The particles were replaced by `cuts`' owners: cuts() holds while one of them is cut.
  void particlesReplaced(const std::vector<CutPlane>& cuts) {
    everCut_ = false;
    for (const CutPlane& c : cuts) everCut_ = everCut_ || isCut(c);
  }

  /// Adds the resistance the tools met over the advance to their bodies' impulses in `out`
  /// (of `particles` particles).
  void addImpulses(std::vector<ContactSums>& out, size_t particles) {
    if (bladeImpulses_.size() == 0) return;
    std::vector<BladeImpulse>& all = bladeImpulsesHost_;  // kept: a suturing scene takes them every tick
    all.resize(bladeImpulses_.size());
    exec_.copyToHost(all.data(), bladeImpulses_.data(), all.size() * sizeof(BladeImpulse));
    for (size_t b = 0; b < bladeBodies_.size(); ++b) {
      double sum[7] = {0, 0, 0, 0, 0, 0, 0};
      for (size_t i = 0; i < particles; ++i) {
        for (int a = 0; a < 3; ++a) {
          sum[a] += all[b * particles + i].linear[a];
          sum[3 + a] += all[b * particles + i].angular[a];
        }
        sum[6] += all[b * particles + i].presence;
      }
      ContactSums& c = out[bladeBodies_[b]];
      for (int a = 0; a < 3; ++a) {
        c.impulse[a] += (float)sum[a];
        c.angular[a] += (float)sum[3 + a];
      }
      // a needle's tip inside has no grid contact: its mass sum carries the time integral
      // of the material's presence ahead of it instead (needleTipResistance)
      c.mass += (float)sum[6];
    }
  }

  /// Whether some particle may carry a cut: a blade is in the scene, or was since the
  /// particles were last replaced. Until then the transfers do not read the cut field.
  bool cuts() const { return everCut_; }
  /// Whether the stage has anything to do this advance (a blade or a needle's tip).
  bool active() const { return blades_ || tips_; }
  /// The impulse the resistance gives each particle this substep (record), null when the
  /// tools of this advance have no such resistance.
  const Vec3f* push() const { return push_.size() > 0 ? push_.data() : nullptr; }

  /// Records the cuts and the resistances of this substep on the `P.count` particles, with
  /// the `nParts` parts in reach (none: the push is zero).
  void record(const ParticleView& P, const PartView* parts, int nParts, const BodyView* bodies,
              const MaterialParams* materials, const GridGeometry& geo, float dt) {
    const bool resisting = bladeImpulses_.size() > 0;
    if (nParts == 0) {
      if (resisting) exec_.forEach(P.count, kernels::Fill<Vec3f>{push_.data(), Vec3f{0.f, 0.f, 0.f}});
      return;
    }
    exec_.forEach(P.count, kernels::RecordCuts{P, parts, cutters_.data(), (int)cutters_.size(), bodies, materials,
                                               resisting ? bladeImpulses_.data() : nullptr,
                                               resisting ? push_.data() : nullptr, geo, dt});
  }

  size_t memoryBytes() const {
    return bladeImpulses_.bytes() + bladeImpulsesHost_.capacity() * sizeof(BladeImpulse) + cutters_.bytes() +
           push_.bytes();
  }

 private:
  Exec& exec_;
  bool blades_ = false;     ///< a slicer's blade is among the parts
  bool tips_ = false;       ///< a needle's tip is inside the material (kPartTipInside)
  bool everCut_ = false;    ///< cuts()
  bool toughness_ = false;  ///< some material resists cutting
  std::vector<int> bladeBodies_;  ///< the body of each resisting part, in part order
  ExecArray<kernels::Cutter, Exec> cutters_;  ///< the parts record visits (setParts)
  ExecArray<BladeImpulse, Exec> bladeImpulses_;
  std::vector<BladeImpulse> bladeImpulsesHost_;  ///< addImpulses' copy
  ExecArray<Vec3f, Exec> push_;  ///< push()
};

}  // namespace mpm
