#include "mpm_bullet/shape_conversion.h"

#include <btBulletCollisionCommon.h>
#include <LinearMath/btConvexHullComputer.h>
#include <BulletCollision/CollisionShapes/btConvexPointCloudShape.h>
#include <BulletCollision/Gimpact/btGImpactShape.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include "mpm/error.h"
#include "mpm/sdf_grid.h"

namespace mpm::bullet {

Vec3f toVec(const btVector3& v) { return {(float)v.x(), (float)v.y(), (float)v.z()}; }

Pose toPose(const btTransform& t) {
  const btQuaternion q = t.getRotation();
  return {toVec(t.getOrigin()), {(float)q.w(), (float)q.x(), (float)q.y(), (float)q.z()}};
}

namespace {

/// Composes parent * child poses.
Pose compose(const Pose& parent, const Pose& child) {
  btTransform p(btQuaternion(parent.rotation.x, parent.rotation.y, parent.rotation.z, parent.rotation.w),
                btVector3(parent.position.x, parent.position.y, parent.position.z));
  btTransform c(btQuaternion(child.rotation.x, child.rotation.y, child.rotation.z, child.rotation.w),
                btVector3(child.position.x, child.position.y, child.position.z));
  return toPose(p * c);
}

/// Collects the triangles of a striding mesh, scaled.
struct TriangleCollector : btInternalTriangleIndexCallback {
  TriangleMesh* mesh;
  void internalProcessTriangleIndex(btVector3* tri, int, int) override {
    for (int i = 0; i < 3; ++i) {
      mesh->indices.push_back((uint32_t)mesh->vertices.size());
      mesh->vertices.push_back(toVec(tri[i]));
    }
  }
};

Geometry meshGeometry(const TriangleMesh& mesh, float cell) {
  Geometry g;
  g.type = GeometryType::Mesh;
  g.sdf = std::make_shared<SignedDistanceGrid>(buildSignedDistanceGrid(mesh, cell));
  return g;
}

TriangleMesh stridingMesh(const btStridingMeshInterface* mi, const btVector3& scaling) {
  TriangleMesh mesh;
  TriangleCollector collector;
  collector.mesh = &mesh;
  const btVector3 big(1e30f, 1e30f, 1e30f);
  // InternalProcessAllTriangles applies the interface's own scaling (a BVH mesh shape
  // keeps its local scaling there); apply whatever part of the shape's scaling is not
  const_cast<btStridingMeshInterface*>(mi)->InternalProcessAllTriangles(&collector, -big, big);
  const btVector3 extra = scaling / mi->getScaling();
  for (Vec3f& v : mesh.vertices) v = {v.x * (float)extra.x(), v.y * (float)extra.y(), v.z * (float)extra.z()};
  return mesh;
}

std::string show(const btVector3& v) {
  std::ostringstream s;
  s << "(" << v.x() << ", " << v.y() << ", " << v.z() << ")";
  return s.str();
}

/// A length as people write it: "0", "0.05" (std::to_string gives "0.000000").
std::string num(double v) {
  std::ostringstream s;
  s << v;
  return s.str();
}

const char* axisName(int a) { return a == 0 ? "x" : a == 1 ? "y" : "z"; }

/// A zero-size Bullet shape (legal there) has no inside for the tissue to touch: refused
/// naming the shape (`what`), the field and what is zero.
[[noreturn]] void refuseZero(const std::string& what, const std::string& field, const std::string& value,
                             const std::string& zero) {
  throw InvalidArgument(what + " " + field, value,
                        zero + ": the shape has no inside for the tissue to touch (MPM contact needs a solid); "
                               "give it a thickness");
}

/// The Bullet class of a shape converted through its hull, for messages.
std::string convexClassName(const btCollisionShape* shape) {
  switch (shape->getShapeType()) {
    case CONVEX_POINT_CLOUD_SHAPE_PROXYTYPE: return "btConvexPointCloudShape";
    case CONVEX_TRIANGLEMESH_SHAPE_PROXYTYPE: return "btConvexTriangleMeshShape";
    default: return "btConvexHullShape";
  }
}

/// A signed distance grid over [lo, hi] plus the padding buildSignedDistanceGrid uses,
/// sampled from an exact distance function; refused (naming `what`) if flat or if no
/// sample lies inside.
template <class Distance>
Geometry sampledGeometry(const btVector3& lo, const btVector3& hi, float cell, Distance distance,
                         const std::string& what) {
  for (int a = 0; a < 3; ++a)
    if (!(hi[a] - lo[a] > 1e-6f))
      refuseZero(what, "bounds", show(lo) + " - " + show(hi), std::string("flat along ") + axisName(a));
  auto sdf = std::make_shared<SignedDistanceGrid>();
  const int pad = 3;
  sdf->cellSize = cell;
  sdf->lower = toVec(lo) - (pad * cell) * Vec3f{1.f, 1.f, 1.f};
  for (int a = 0; a < 3; ++a) sdf->dims[a] = (int)std::ceil((hi[a] - lo[a]) / cell) + 2 * pad + 1;
  sdf->values.resize((size_t)sdf->dims[0] * sdf->dims[1] * sdf->dims[2]);
  bool inside = false;
  for (int i = 0; i < sdf->dims[0]; ++i)
    for (int j = 0; j < sdf->dims[1]; ++j)
      for (int k = 0; k < sdf->dims[2]; ++k) {
        const btVector3 p(sdf->lower.x + i * cell, sdf->lower.y + j * cell, sdf->lower.z + k * cell);
        const float v = (float)distance(p);
        sdf->values[((size_t)i * sdf->dims[1] + j) * sdf->dims[2] + k] = v;
        inside = inside || v < 0.f;
      }
  if (!inside)
    refuseZero(what, "samples", "none inside",
               "thinner than the sampling (sdfCellSize = " + num(cell) + " m) or flat");
  Geometry g;
  g.type = GeometryType::Mesh;
  g.sdf = std::move(sdf);
  return g;
}

/// Bullet's cone (apex at +height/2 on the up axis, base of `radius` at -height/2) grown by
/// its collision margin, as Bullet collides with it (support vertex plus margin times the
/// direction): the solid cone's exact distance, from its cross-section triangle in the
/// (distance from the axis, height) plane, less the margin.
Geometry coneGeometry(const btConeShape* c, float cell, const std::string& what) {
  const double r = c->getRadius(), h = c->getHeight(), m = c->getMargin();
  const int up = c->getConeUpIndex();
  // with a margin, a cone of zero radius or height is still a solid (Bullet rounds it)
  if (!(r > 0.0) && !(m > 0.0)) refuseZero(what, "radius", num(r), "a line");
  if (!(h > 0.0) && !(m > 0.0)) refuseZero(what, "height", num(h), "a flat disc");
  auto distance = [=](const btVector3& p) {
    const double u = p[(up + 1) % 3], w = p[(up + 2) % 3];
    const double qy = p[up], qx = std::sqrt(u * u + w * w);  // along the axis; from it
    auto segment = [&](double ax, double ay, double bx, double by) {
      const double ex = bx - ax, ey = by - ay, len2 = ex * ex + ey * ey;
      const double t = len2 > 0 ? std::clamp(((qx - ax) * ex + (qy - ay) * ey) / len2, 0.0, 1.0) : 0.0;
      return std::hypot(qx - ax - t * ex, qy - ay - t * ey);
    };
    const double d = std::min(segment(0, h / 2, r, -h / 2), segment(r, -h / 2, 0, -h / 2));
    const bool inside = qy > -h / 2 && qx * h < r * (h / 2 - qy);
    return (inside ? -d : d) - m;
  };
  btVector3 hi(0, 0, 0);
  hi[up] = (btScalar)(h / 2 + m);
  hi[(up + 1) % 3] = hi[(up + 2) % 3] = (btScalar)(r + m);
  btVector3 lo = -hi;
  lo[up] = (btScalar)(-h / 2 - m);
  return sampledGeometry(lo, hi, cell, distance, what);
}

/// Bullet's multi-sphere is the convex hull of its spheres (support: centre plus radius
/// times the direction; its margin is taken off and added back). One sphere is a sphere;
/// two are a round cone, sampled from its exact distance (Quilez's closed form).
Geometry multiSphereGeometry(const btMultiSphereShape* ms, const Pose& local, float cell, const std::string& what) {
  const btVector3 sc = ms->getLocalScaling();
  if (!(sc.x() == sc.y() && sc.y() == sc.z()))
    throw InvalidArgument(what + " local scaling", show(sc),
                          "only uniform scaling is supported (Bullet turns its spheres into ellipsoids otherwise)");
  const int n = ms->getSphereCount();
  if (n < 1 || n > 2)
    throw InvalidArgument(what + " sphere count", std::to_string(n),
                          "one or two spheres are supported (the hull of more has no exact distance here); use a "
                          "btConvexHullShape or a compound");
  const btVector3 a = ms->getSpherePosition(0) * sc, b = ms->getSpherePosition(n - 1) * sc;
  const double ra = ms->getSphereRadius(0) * sc.x(), rb = ms->getSphereRadius(n - 1) * sc.x();
  if (!(std::max(ra, rb) > 0.0)) refuseZero(what, "radii", num(ra) + ", " + num(rb), "points");
  if (n == 1 || (a - b).length() + std::min(ra, rb) <= std::max(ra, rb)) {
    // one sphere, or one sphere holding the other: the bigger one, exactly
    Geometry g = Geometry::sphere((float)std::max(ra, rb));
    g.localPose = compose(local, Pose{toVec(ra >= rb ? a : b), Quat{}});
    return g;
  }
  auto distance = [=](const btVector3& p) {
    const btVector3 ba = b - a, pa = p - a;
    const double l2 = ba.dot(ba), rr = ra - rb, a2 = l2 - rr * rr, il2 = 1.0 / l2;
    const double y = pa.dot(ba), z = y - l2;
    const btVector3 c = pa * (btScalar)l2 - ba * (btScalar)y;
    const double x2 = c.dot(c), y2 = y * y * l2, z2 = z * z * l2;
    const double k = (rr > 0 ? 1 : rr < 0 ? -1 : 0) * rr * rr * x2;
    if ((z > 0 ? 1 : -1) * a2 * z2 > k) return std::sqrt(x2 + z2) * il2 - rb;
    if ((y > 0 ? 1 : -1) * a2 * y2 < k) return std::sqrt(x2 + y2) * il2 - ra;
    return (std::sqrt(x2 * a2 * il2) + y * rr) * il2 - ra;
  };
  btVector3 lo = a - btVector3(1, 1, 1) * (btScalar)ra, hi = a + btVector3(1, 1, 1) * (btScalar)ra;
  lo.setMin(b - btVector3(1, 1, 1) * (btScalar)rb);
  hi.setMax(b + btVector3(1, 1, 1) * (btScalar)rb);
  Geometry g = sampledGeometry(lo, hi, cell, distance, what);
  g.localPose = local;
  return g;
}

/// A convex hull, point cloud or convex triangle mesh as Bullet collides with it: the
/// hull of its scaled points grown by its margin (support vertex plus margin times the
/// direction), i.e. the hull's triangle-mesh distance less the margin, exact at the
/// samples. (btShapeHull, used before, samples the surface in 42 directions: 4.5 mm off on
/// a 5 cm hull of 400 points.) Flat points with a margin are a rounded plate.
Geometry hullGeometry(const btConvexShape* shape, float cell, const std::string& what) {
  std::vector<btVector3> points;
  const btVector3 scaling = shape->getLocalScaling();
  if (shape->getShapeType() == CONVEX_HULL_SHAPE_PROXYTYPE) {
    auto* h = static_cast<const btConvexHullShape*>(shape);
    for (int i = 0; i < h->getNumPoints(); ++i) points.push_back(h->getUnscaledPoints()[i] * scaling);
  } else if (shape->getShapeType() == CONVEX_POINT_CLOUD_SHAPE_PROXYTYPE) {
    auto* c = static_cast<const btConvexPointCloudShape*>(shape);
    for (int i = 0; i < c->getNumPoints(); ++i) points.push_back(c->getUnscaledPoints()[i] * scaling);
  } else {  // its mesh interface carries the scaling
    auto* m = static_cast<const btConvexTriangleMeshShape*>(shape);
    for (const Vec3f& v : stridingMesh(m->getMeshInterface(), scaling).vertices) points.emplace_back(v.x, v.y, v.z);
  }
  btConvexHullComputer hull;
  if (!points.empty()) hull.compute(&points[0].x(), sizeof(btVector3), (int)points.size(), 0.f, 0.f);
  if (hull.vertices.size() < 3)
    refuseZero(what, "points", num(hull.vertices.size()) + " distinct",
               "a point or a segment (a btSphereShape or btCapsuleShape is that exactly)");
  const double margin = shape->getMargin();
  const bool flat = hull.faces.size() < 4;  // a polygon: its two sides
  if (flat && !(margin > 0.0)) refuseZero(what, "hull", "flat", "flat points (no tetrahedron) and no margin");
  TriangleMesh mesh;
  for (int i = 0; i < hull.vertices.size(); ++i) mesh.vertices.push_back(toVec(hull.vertices[i]));
  for (int f = 0; f < hull.faces.size(); ++f) {  // each face a fan from its first vertex
    const btConvexHullComputer::Edge* first = &hull.edges[hull.faces[f]];
    for (const btConvexHullComputer::Edge* e = first->getNextEdgeOfFace(); e->getTargetVertex() != first->getSourceVertex();
         e = e->getNextEdgeOfFace())
      mesh.indices.insert(mesh.indices.end(), {(uint32_t)first->getSourceVertex(), (uint32_t)e->getSourceVertex(),
                                               (uint32_t)e->getTargetVertex()});
  }
  auto sdf = std::make_shared<SignedDistanceGrid>(
      buildSignedDistanceGrid(mesh, cell, 3 + (int)std::ceil(margin / cell)));  // room for the margin
  for (float& v : sdf->values) v = (flat ? std::fabs(v) : v) - (float)margin;
  sdf->signReliable = true;  // a closed hull, or a plate whose distance needs no sign
  sdf->signWarning.clear();
  Geometry g;
  g.type = GeometryType::Mesh;
  g.sdf = std::move(sdf);
  return g;
}

void convertInto(const btCollisionShape* shape, const Pose& local, float cell, std::vector<Geometry>& out,
                 const std::string& where) {
  Geometry g;
  g.localPose = local;
  switch (shape->getShapeType()) {
    case BOX_SHAPE_PROXYTYPE: {
      auto* box = static_cast<const btBoxShape*>(shape);
      g.type = GeometryType::Box;
      const btVector3 h = box->getHalfExtentsWithMargin();  // scaling is baked in
      for (int a = 0; a < 3; ++a)
        if (!(h[a] > 0.f)) refuseZero(where + "btBoxShape", "half extents", show(h), std::string("zero along ") + axisName(a));
      g.halfExtents = toVec(h);
      break;
    }
    case SPHERE_SHAPE_PROXYTYPE: {
      auto* s = static_cast<const btSphereShape*>(shape);
      g.type = GeometryType::Sphere;
      g.radius = (float)s->getRadius();
      if (!(g.radius > 0.f)) refuseZero(where + "btSphereShape", "radius", num(g.radius), "a point");
      break;
    }
    case CAPSULE_SHAPE_PROXYTYPE: {
      auto* c = static_cast<const btCapsuleShape*>(shape);
      g.axis = c->getUpAxis();
      g.radius = (float)c->getRadius();
      g.halfHeight = (float)c->getHalfHeight();
      if (!(g.radius > 0.f)) refuseZero(where + "btCapsuleShape", "radius", num(g.radius), "a segment");
      // a capsule whose cylinder part has zero height (legal in Bullet) is exactly a sphere
      g.type = g.halfHeight > 0.f ? GeometryType::Capsule : GeometryType::Sphere;
      break;
    }
    case CYLINDER_SHAPE_PROXYTYPE: {
      auto* c = static_cast<const btCylinderShape*>(shape);
      g.type = GeometryType::Cylinder;
      g.axis = c->getUpAxis();
      const btVector3 h = c->getHalfExtentsWithMargin();
      g.halfHeight = (float)h[g.axis];
      g.radius = (float)h[(g.axis + 1) % 3];
      if (!(g.halfHeight > 0.f))
        refuseZero(where + "btCylinderShape", "half height", num(g.halfHeight), "a flat disc");
      if (!(g.radius > 0.f)) refuseZero(where + "btCylinderShape", "radius", num(g.radius), "a line");
      break;
    }
    case STATIC_PLANE_PROXYTYPE: {
      // n . x = d: our plane is y <= 0 in its frame; rotate y onto n, move to d n
      auto* p = static_cast<const btStaticPlaneShape*>(shape);
      const btVector3 n = p->getPlaneNormal().normalized();
      const btQuaternion q = btVector3(0, 1, 0).dot(n) < -0.9999f
                                 ? btQuaternion(btVector3(1, 0, 0), SIMD_PI)
                                 : shortestArcQuat(btVector3(0, 1, 0), n);
      g.type = GeometryType::Plane;
      g.localPose = compose(local, toPose(btTransform(q, n * p->getPlaneConstant())));
      break;
    }
    case COMPOUND_SHAPE_PROXYTYPE: {
      auto* c = static_cast<const btCompoundShape*>(shape);
      for (int i = 0; i < c->getNumChildShapes(); ++i)
        convertInto(c->getChildShape(i), compose(local, toPose(c->getChildTransform(i))), cell, out,
                    where + "btCompoundShape child " + std::to_string(i) + ": ");
      return;
    }
    case CONVEX_HULL_SHAPE_PROXYTYPE:
    case CONVEX_POINT_CLOUD_SHAPE_PROXYTYPE:
    case CONVEX_TRIANGLEMESH_SHAPE_PROXYTYPE:
      g = hullGeometry(static_cast<const btConvexShape*>(shape), cell, where + convexClassName(shape));
      g.localPose = local;
      break;
    case TRIANGLE_MESH_SHAPE_PROXYTYPE: {
      auto* m = static_cast<const btBvhTriangleMeshShape*>(shape);
      g = meshGeometry(stridingMesh(m->getMeshInterface(), m->getLocalScaling()), cell);
      g.localPose = local;
      break;
    }
    case GIMPACT_SHAPE_PROXYTYPE: {
      auto* m = static_cast<const btGImpactMeshShape*>(shape);
      g = meshGeometry(stridingMesh(m->getMeshInterface(), m->getLocalScaling()), cell);
      g.localPose = local;
      break;
    }
    case SCALED_TRIANGLE_MESH_SHAPE_PROXYTYPE: {
      // a shared BVH mesh with its own scaling on top of the mesh's
      auto* m = static_cast<const btScaledBvhTriangleMeshShape*>(shape);
      const btBvhTriangleMeshShape* child = m->getChildShape();
      g = meshGeometry(stridingMesh(child->getMeshInterface(), child->getLocalScaling() * m->getLocalScaling()), cell);
      g.localPose = local;
      break;
    }
    case CONE_SHAPE_PROXYTYPE:
      g = coneGeometry(static_cast<const btConeShape*>(shape), cell, where + "btConeShape");
      g.localPose = local;
      break;
    case MULTI_SPHERE_SHAPE_PROXYTYPE:
      g = multiSphereGeometry(static_cast<const btMultiSphereShape*>(shape), local, cell, where + "btMultiSphereShape");
      break;
    default:
      throw InvalidArgument(where + "btCollisionShape", shape->getName(),
                            "cannot be converted to an MPM shape (supported: static plane, box, sphere, capsule, "
                            "cylinder, cone, multi-sphere of one or two spheres, convex hull, convex point cloud, "
                            "convex triangle mesh, compound, BVH triangle mesh (scaled too), GImpact mesh)");
  }
  out.push_back(g);
}

}  // namespace

std::vector<Geometry> convertShape(const btCollisionShape* shape, float sdfCellSize) {
  if (!shape) throw InvalidArgument("btCollisionShape", "null", "no shape given");
  std::vector<Geometry> parts;
  convertInto(shape, Pose{}, sdfCellSize, parts, "");
  return parts;
}

}  // namespace mpm::bullet
