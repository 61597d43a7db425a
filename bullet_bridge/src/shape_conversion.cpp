#include "mpm_bullet/shape_conversion.h"

#include <btBulletCollisionCommon.h>
#include <BulletCollision/CollisionShapes/btShapeHull.h>
#include <BulletCollision/Gimpact/btGImpactShape.h>

#include <memory>
#include <string>

#include "mpm/error.h"
#include "mpm/sdf_grid.h"

namespace mpm::bullet {

namespace {

Vec3f toVec(const btVector3& v) { return {(float)v.x(), (float)v.y(), (float)v.z()}; }

Pose toPose(const btTransform& t) {
  const btQuaternion q = t.getRotation();
  return {toVec(t.getOrigin()), {(float)q.w(), (float)q.x(), (float)q.y(), (float)q.z()}};
}

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

void convertInto(const btCollisionShape* shape, const Pose& local, float cell, std::vector<Geometry>& out) {
  Geometry g;
  g.localPose = local;
  switch (shape->getShapeType()) {
    case BOX_SHAPE_PROXYTYPE: {
      auto* box = static_cast<const btBoxShape*>(shape);
      g.type = GeometryType::Box;
      g.halfExtents = toVec(box->getHalfExtentsWithMargin());  // scaling is baked in
      break;
    }
    case SPHERE_SHAPE_PROXYTYPE: {
      auto* s = static_cast<const btSphereShape*>(shape);
      g.type = GeometryType::Sphere;
      g.radius = (float)s->getRadius();
      break;
    }
    case CAPSULE_SHAPE_PROXYTYPE: {
      auto* c = static_cast<const btCapsuleShape*>(shape);
      g.type = GeometryType::Capsule;
      g.axis = c->getUpAxis();
      g.radius = (float)c->getRadius();
      g.halfHeight = (float)c->getHalfHeight();
      break;
    }
    case CYLINDER_SHAPE_PROXYTYPE: {
      auto* c = static_cast<const btCylinderShape*>(shape);
      g.type = GeometryType::Cylinder;
      g.axis = c->getUpAxis();
      const btVector3 h = c->getHalfExtentsWithMargin();
      g.halfHeight = (float)h[g.axis];
      g.radius = (float)h[(g.axis + 1) % 3];
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
        convertInto(c->getChildShape(i), compose(local, toPose(c->getChildTransform(i))), cell, out);
      return;
    }
    case CONVEX_HULL_SHAPE_PROXYTYPE: {
      // the hull's triangles (btShapeHull includes the shape's scaling)
      btShapeHull hull(static_cast<const btConvexShape*>(shape));
      hull.buildHull(0);
      TriangleMesh mesh;
      for (int i = 0; i < hull.numVertices(); ++i) mesh.vertices.push_back(toVec(hull.getVertexPointer()[i]));
      for (int i = 0; i < hull.numIndices(); ++i) mesh.indices.push_back(hull.getIndexPointer()[i]);
      g = meshGeometry(mesh, cell);
      g.localPose = local;
      break;
    }
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
    default:
      throw InvalidArgument("btCollisionShape", shape->getName(),
                            "cannot be converted to an MPM shape (supported: box, sphere, capsule, "
                            "cylinder, static plane, compound, convex hull, BVH triangle mesh, GImpact mesh)");
  }
  out.push_back(g);
}

}  // namespace

std::vector<Geometry> convertShape(const btCollisionShape* shape, float sdfCellSize) {
  if (!shape) throw InvalidArgument("btCollisionShape", "null", "no shape given");
  std::vector<Geometry> parts;
  convertInto(shape, Pose{}, sdfCellSize, parts);
  return parts;
}

}  // namespace mpm::bullet
