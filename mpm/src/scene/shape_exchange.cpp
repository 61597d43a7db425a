#include "scene/shape_exchange.h"

#include <algorithm>
#include <cmath>
#include <memory>

#include "contact/contact_law.h"
#include "scene/substep_policy.h"
#include "shapes/shape_builder.h"
#include "tools/tool_builder.h"
#include "solvers/solver_list.h"

namespace mpm {

namespace {

/// Least contact band of a Bonded shape: half a cell on a grid, so the node layer
/// nearest its face always follows it (with band 0 the layer just outside the face is
/// free: a bonded plate let go of a cylinder it pulled once it had moved about a cell,
/// and a compressed one measured 23 % soft at H = 10 dx). MTLED's nodes are tested at
/// their own positions: its band is the shape's own.
float bondedBand(const SceneSettings& s) { return solverTraits(s.solver).meshless ? 0.f : 0.5f * s.dx; }
/// How far from a Bonded shape material that touched it stays glued (BodyView::glueReach):
/// as far as the nodes it holds reach (kGluedReach). MTLED: nothing glued (its contact
/// has no touching share).
float glueReach(const SceneSettings& s) { return solverTraits(s.solver).meshless ? 0.f : kGluedReach * s.dx; }
/// Least half-thickness of a part on a grid, 0.75 dx: a thinner rod, plate or sphere
/// gets the band that makes up the difference (PartView::band). MTLED: none.
float thinPartHalfThickness(const SceneSettings& s) { return solverTraits(s.solver).meshless ? 0.f : 0.75f * s.dx; }

/// Radius of a needle's and of a thread's contact region on a grid [m].
float curveReach(const SceneSettings& s) { return kCurveReach * s.dx; }
float threadReach(const SceneSettings& s) { return kThreadReach * s.dx; }

/// Where the parts are anchored (PartView): the domain's centre.
Vec3f domainCentre(const SceneSettings& s) { return 0.5f * (s.domain.lower + s.domain.upper); }

bool moved(const BodyView& b) {
  bool any = false;
  for (int i = 0; i < 3; ++i) {
    any = any || b.travel[i] != 0.0;
    for (int j = 0; j < 3; ++j) any = any || b.turn[i][j] != 0.0;
  }
  return any;
}

}  // namespace

float trackPressurePerDensity(const ObjectTable& objects) {
  float most = 0.f;
  for (size_t i = 0; i < objects.size(); ++i)
    if (objects.alive(i)) {
      const MaterialParams& m = objects[i].material;
      most = std::max(most, m.mu / m.density);
    }
  return most;
}

BodyMap uploadShapes(const ShapeTable& shapes, const SlicerTable& slicers, const CurveTable& curves,
                     const ObjectTable& objects, const SceneSettings& settings, SimBackend& backend) {
  std::vector<BodyView> bodies;
  std::vector<PartView> parts;
  std::vector<const SignedDistanceGrid*> meshes;
  BodyMap map;
  map.shapes.assign(shapes.size(), -1);
  map.slicers.assign(slicers.size(), -1);
  for (size_t i = 0; i < shapes.size(); ++i) {
    if (!shapes.alive(i)) continue;
    const int b = (int)bodies.size();
    map.shapes[i] = b;
    bodies.push_back(makeBody(shapes[i].desc, shapes[i].state, bondedBand(settings)));
    if (bodies.back().mode == kContactBonded) bodies.back().glueReach = glueReach(settings);
    appendParts(shapes[i].desc, shapes[i].state, b, thinPartHalfThickness(settings), domainCentre(settings),
                [&](const std::shared_ptr<const SignedDistanceGrid>& g) {
      meshes.push_back(g.get());
      return backend.meshValues(g);
    }, parts);
  }
  for (size_t i = 0; i < slicers.size(); ++i) {
    if (!slicers.alive(i)) continue;
    map.slicers[i] = (int)bodies.size();
    // the faces push the material out of a band of half a cell (the gap a cut opens)
    const CurvedBlade* curved = slicers[i].curved.get();
    const float* values = nullptr;
    if (curved) {
      meshes.push_back(curved->grid.get());
      values = backend.meshValues(curved->grid);
    }
    appendSlicer(slicers[i].desc, slicers[i].state, 0.5f * settings.dx, domainCentre(settings), curved, values, bodies,
                 parts);
  }
  map.curves.assign(curves.size(), -1);
  const float pressure = trackPressurePerDensity(objects);
  for (size_t i = 0; i < curves.size(); ++i) {
    if (!curves.alive(i)) continue;
    map.curves[i] = (int)bodies.size();
    const CurveRecord& c = curves[i];
    if (c.needle)
      appendNeedle(c.arc, c.state, c.tipInside(), curveReach(settings), settings.dx, pressure,
                   domainCentre(settings), bodies, parts);
    else
      appendThread(c.thread, c.thread.points, c.thread.velocities, threadReach(settings),
                   domainCentre(settings), bodies, parts);
  }
  backend.releaseMeshesExcept(meshes);
  backend.setShapes(bodies, parts);
  return map;
}

namespace {
ShapeImpulse impulseOf(const ContactSums& c) {
  return {{c.impulse[0], c.impulse[1], c.impulse[2]}, {c.angular[0], c.angular[1], c.angular[2]}};
}

/// A body's pose after the substeps moved it. A body they did not move keeps its pose as
/// given: read back from the float matrix and origin it would drift by their rounding
/// every advance.
void readPose(const BodyView& b, Pose& pose) {
  if (!moved(b)) return;
  pose.position = b.shapeOrigin;
  pose.rotation = quaternionFromMatrix(b.rotation);
}
}  // namespace

namespace {
/// The material's presence ahead of a needle's tip (needleTipResistance: 1 where its half
/// ball is full) at which the tip counts as deep in the material, and below which a deep
/// tip has a surface within its reach ahead. Measured inside a block (dx 2.5 mm) the
/// presence averaged over an advance of 5 ms ranged 0.63-1.39; leaving through a surface
/// it fell to 0.30-0.34.
constexpr float kTipDeepPresence = 0.75f;
constexpr float kTipSurfacePresence = 0.4f;

/// A needle's tip after an advance of `dt` whose tip body took `tip` (TipState): a blunt tip
/// breaks in when it pressed on the material along its tangent with punctureForce or more;
/// one inside comes out when the material's presence ahead of it (the sums' mass,
/// needleTipResistance) averaged under a hundredth of the half ball's; a deep one meets a
/// far surface below kTipSurfacePresence and is blunt again.
void updateTip(CurveRecord& c, const ContactSums& tip, float dt) {
  const float a = c.arc.endAngle;
  const Vec3f t = rotationMatrix(c.state.pose.rotation) * Vec3f{-std::sin(a), std::cos(a), 0.f};
  const float presence = tip.mass / dt;
  switch (c.tip) {
    case TipState::kOutside: {
      const float pressing = -dot(Vec3f{tip.impulse[0], tip.impulse[1], tip.impulse[2]}, t) / dt;
      if (pressing > 0.f && pressing >= c.arc.punctureForce) c.tip = TipState::kEntering;
      break;
    }
    case TipState::kEntering:
      if (presence < 0.01f) c.tip = TipState::kOutside;
      else if (presence >= kTipDeepPresence) c.tip = TipState::kDeep;
      break;
    case TipState::kDeep:
      if (presence < kTipSurfacePresence) c.tip = TipState::kOutside;
      break;
  }
}
}  // namespace

void downloadShapes(ShapeTable& shapes, SlicerTable& slicers, CurveTable& curves, const BodyMap& map, float dt,
                    SimBackend& backend) {
  std::vector<BodyView> bodies;
  backend.readBodies(bodies);
  const std::vector<ContactSums> impulses = backend.takeImpulses();
  for (size_t i = 0; i < curves.size(); ++i) {
    const int b = i < map.curves.size() ? map.curves[i] : -1;
    if (!curves.alive(i) || b < 0) continue;
    CurveRecord& c = curves[i];
    c.impulses.resize(c.bodyCount());
    c.contactMasses.resize(c.bodyCount());
    for (size_t k = 0; k < c.bodyCount(); ++k) {
      c.impulses[k] = impulseOf(impulses[b + k]);
      c.contactMasses[k] = dt > 0.f ? impulses[b + k].mass / dt : 0.f;
    }
    if (!c.needle) continue;
    readPose(bodies[b], c.state.pose);  // kinematic: it moved on with its velocity
    updateTip(c, impulses[b + 1], dt);
  }
  for (size_t i = 0; i < slicers.size(); ++i) {
    const int b = i < map.slicers.size() ? map.slicers[i] : -1;
    if (!slicers.alive(i) || b < 0) continue;
    // the faces' and the spine's, about the slicer's frame origin (both bodies' centre)
    const ShapeImpulse faces = impulseOf(impulses[b]), spine = impulseOf(impulses[b + 1]);
    slicers[i].lastImpulse = {faces.linear + spine.linear, faces.angular + spine.angular};
    readPose(bodies[b], slicers[i].state.pose);  // kinematic: it moved on with its velocity
  }
  const std::vector<int>& bodyOfShape = map.shapes;
  for (size_t i = 0; i < shapes.size(); ++i) {
    const int b = i < bodyOfShape.size() ? bodyOfShape[i] : -1;
    if (!shapes.alive(i) || b < 0) continue;
    ShapeState& st = shapes[i].state;
    readPose(bodies[b], st.pose);
    st.linearVelocity = bodies[b].linearVelocity;
    st.angularVelocity = bodies[b].angularVelocity;
    shapes[i].lastImpulse = impulseOf(impulses[b]);
  }
}

void checkSpeed(const char* prefix, const ShapeRecord& r, const ShapeState& s, const SceneSettings& settings) {
  const float planeReach = norm(settings.domain.upper - settings.domain.lower);
  validateSpeed(prefix, s, reachOf(r.desc, planeReach), SubstepBounds::maxShapeSpeed(settings));
}
void checkSpeed(const char* prefix, const SlicerRecord& r, const ShapeState& s, const SceneSettings& settings) {
  validateSpeed(prefix, s, reachOf(r.desc, r.curved.get()), SubstepBounds::maxShapeSpeed(settings));
}
void checkSpeed(const char* prefix, const CurveRecord& needle, const ShapeState& s, const SceneSettings& settings) {
  validateSpeed(prefix, s, needle.arc.radius, SubstepBounds::maxShapeSpeed(settings));  // its tip
}

}  // namespace mpm
