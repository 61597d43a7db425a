// Coupler::debugDraw: the tissue's particles and the tools as the scene moved them, drawn
// through Bullet's btIDebugDraw.
#include "coupler_links.h"

#include <LinearMath/btIDebugDraw.h>

#include <cmath>
#include <string>

namespace mpm::bullet {

namespace {
btTransform toTransform(const Pose& p) {
  return btTransform(btQuaternion(p.rotation.x, p.rotation.y, p.rotation.z, p.rotation.w), toBt(p.position));
}
}  // namespace

void Coupler::debugDraw(btIDebugDraw* drawer, const DebugDrawOptions& options) const {
  if (!drawer) drawer = world_->getDebugDrawer();
  if (!drawer || drawer->getDebugMode() == btIDebugDraw::DBG_NoDebug) return;
  if (!(options.particleSize >= 0.f) || !std::isfinite(options.particleSize))
    throw InvalidArgument("DebugDrawOptions.particleSize", std::to_string(options.particleSize), "must be finite and >= 0");
  if (options.particleStride < 1)
    throw InvalidArgument("DebugDrawOptions.particleStride", std::to_string(options.particleStride), "must be >= 1");
  const float half = 0.5f * (options.particleSize > 0.f ? options.particleSize : 0.25f * scene_.settings().dx);
  const btVector3 tissue = toBt(options.tissueColor), tool = toBt(options.toolColor);
  // the tissue: a cross through each particle, its lines along the world axes
  std::vector<Vec3f> x;
  for (const ParticleObjectId id : scene_.particleObjects()) {
    scene_.readPositions(id, x);
    for (size_t i = 0; i < x.size(); i += (size_t)options.particleStride)
      for (int axis = 0; axis < 3; ++axis) {
        btVector3 h(0, 0, 0);
        h[axis] = half;
        drawer->drawLine(toBt(x[i]) - h, toBt(x[i]) + h, tissue);
      }
  }
  // blades: edge, ends and spine's axis as the scene moved them (the coupler takes quad
  // blades only, so there is no mesh blade to draw)
  for (const SlicerLink& l : slicers_) {
    const btTransform t = toTransform(scene_.slicerState(l.slicer).pose);
    const btScalar a = l.blade.halfLength, w = l.blade.width;
    const btVector3 corner[4] = {t * btVector3(-a, 0, 0), t * btVector3(a, 0, 0), t * btVector3(a, w, 0),
                                 t * btVector3(-a, w, 0)};
    for (int k = 0; k < 4; ++k) drawer->drawLine(corner[k], corner[(k + 1) % 4], tool);
  }
  // needles: the wire's centre line, tail to tip, in the arc's x-y plane
  for (const NeedleLink& l : needles_) {
    const btTransform t = toTransform(scene_.curveState(l.curve).pose);
    const ArcDesc& arc = l.needle;
    auto at = [&](float angle) { return t * btVector3(arc.radius * std::cos(angle), arc.radius * std::sin(angle), 0); };
    const int segments = 32;
    for (int k = 0; k < segments; ++k)
      drawer->drawLine(at(arc.startAngle + (arc.endAngle - arc.startAngle) * k / segments),
                       at(arc.startAngle + (arc.endAngle - arc.startAngle) * (k + 1) / segments), tool);
  }
  // threads: the chain as it is now (the points the scene takes at the next tick)
  for (const ThreadLink& t : threads_) {
    const std::vector<btVector3> p = threadPoints(t.thread);
    for (size_t k = 1; k < p.size(); ++k) drawer->drawLine(p[k - 1], p[k], toBt(options.threadColor));
  }
}

}  // namespace mpm::bullet
