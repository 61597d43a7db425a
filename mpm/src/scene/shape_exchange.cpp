#include "scene/shape_exchange.h"

#include <memory>

#include "shapes/shape_builder.h"
#include "solvers/solver_list.h"

namespace mpm {

namespace {

/// Least contact band of a Bonded shape: half a cell on a grid, so the node layer
/// nearest its face always follows it (with band 0 the layer just outside the face is
/// free: a bonded plate let go of a cylinder it pulled once it had moved about a cell,
/// and a compressed one measured 23 % soft at H = 10 dx). MTLED's nodes are tested at
/// their own positions: its band is the shape's own.
float bondedBand(const SceneSettings& s) { return solverTraits(s.solver).meshless ? 0.f : 0.5f * s.dx; }
/// Least half-thickness of a part on a grid, 0.75 dx: a thinner rod, plate or sphere
/// gets the band that makes up the difference (PartView::band). MTLED: none.
float thinPartHalfThickness(const SceneSettings& s) { return solverTraits(s.solver).meshless ? 0.f : 0.75f * s.dx; }

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

std::vector<int> uploadShapes(const ShapeTable& shapes, const SceneSettings& settings, SimBackend& backend) {
  std::vector<BodyView> bodies;
  std::vector<PartView> parts;
  std::vector<const SignedDistanceGrid*> meshes;
  std::vector<int> bodyOfShape(shapes.size(), -1);
  for (size_t i = 0; i < shapes.size(); ++i) {
    if (!shapes.alive(i)) continue;
    const int b = (int)bodies.size();
    bodyOfShape[i] = b;
    bodies.push_back(makeBody(shapes[i].desc, shapes[i].state, bondedBand(settings)));
    appendParts(shapes[i].desc, shapes[i].state, b, thinPartHalfThickness(settings), domainCentre(settings),
                [&](const std::shared_ptr<const SignedDistanceGrid>& g) {
      meshes.push_back(g.get());
      return backend.meshValues(g);
    }, parts);
  }
  backend.releaseMeshesExcept(meshes);
  backend.setShapes(bodies, parts);
  return bodyOfShape;
}

void downloadShapes(ShapeTable& shapes, const std::vector<int>& bodyOfShape, SimBackend& backend) {
  std::vector<BodyView> bodies;
  backend.readBodies(bodies);
  const std::vector<ContactSums> impulses = backend.takeImpulses();
  for (size_t i = 0; i < shapes.size(); ++i) {
    const int b = i < bodyOfShape.size() ? bodyOfShape[i] : -1;
    if (!shapes.alive(i) || b < 0) continue;
    ShapeState& st = shapes[i].state;
    // a body the substeps did not move keeps its pose as given: read back from the
    // float matrix and origin it would drift by their rounding every advance
    if (moved(bodies[b])) {
      st.pose.position = bodies[b].shapeOrigin;
      st.pose.rotation = quaternionFromMatrix(bodies[b].rotation);
    }
    st.linearVelocity = bodies[b].linearVelocity;
    st.angularVelocity = bodies[b].angularVelocity;
    const ContactSums& c = impulses[b];
    shapes[i].lastImpulse = {{c.impulse[0], c.impulse[1], c.impulse[2]}, {c.angular[0], c.angular[1], c.angular[2]}};
  }
}

}  // namespace mpm
