// A frame's picture (the tissue, coloured bodies, needles and threads through the splat
// renderer), its PLY files (the tissue's particles; the tools as points and polylines) and its CSV row.
#include <algorithm>
#include <cmath>
#include <sstream>

#include "scene_file/readers.h"

namespace mpm::bullet {

using namespace scene_file;

namespace {

Vec3f vec(const btVector3& v) { return {(float)v.x(), (float)v.y(), (float)v.z()}; }

/// Points along a polyline `spacing` apart (at most 256 per segment: a huge tool in a
/// scene file must not make the picture take forever), to draw it as splats.
void addPolyline(const std::vector<btVector3>& p, float spacing, std::vector<Vec3f>& out) {
  for (size_t k = 0; k + 1 < p.size(); ++k) {
    const int n = (int)std::clamp(std::ceil((p[k + 1] - p[k]).length() / spacing), 1.f, 256.f);
    for (int i = 0; i < n; ++i) out.push_back(vec(p[k] + (p[k + 1] - p[k]) * ((float)i / n)));
  }
  if (!p.empty()) out.push_back(vec(p.back()));
}

/// Is the body-local point p inside a box, sphere, capsule or cylinder shape (Bullet's
/// capsule and cylinder along their up axis, local y as the scene file makes them)?
bool inside(const btCollisionShape* shape, const btVector3& p) {
  switch (shape->getShapeType()) {
    case BOX_SHAPE_PROXYTYPE: {  // Bullet's box bounds include its margin
      const btVector3 h = static_cast<const btBoxShape*>(shape)->getHalfExtentsWithMargin();
      return std::fabs(p.x()) <= h.x() && std::fabs(p.y()) <= h.y() && std::fabs(p.z()) <= h.z();
    }
    case SPHERE_SHAPE_PROXYTYPE: return p.length() <= static_cast<const btSphereShape*>(shape)->getRadius();
    case CAPSULE_SHAPE_PROXYTYPE: {  // within the radius of the axis segment
      const auto* c = static_cast<const btCapsuleShape*>(shape);
      const int up = c->getUpAxis();
      btVector3 axis(0, 0, 0);
      axis[up] = std::clamp(p[up], -c->getHalfHeight(), c->getHalfHeight());
      return (p - axis).length() <= c->getRadius();
    }
    case CYLINDER_SHAPE_PROXYTYPE: {
      const auto* c = static_cast<const btCylinderShape*>(shape);
      const int up = c->getUpAxis();
      btVector3 radial = p;
      radial[up] = 0;
      return std::fabs(p[up]) <= c->getHalfExtentsWithMargin()[up] && radial.length() <= c->getRadius();
    }
    default: return false;
  }
}

/// Body-local points that show a coloured body, about `spacing` [m] apart: a lattice
/// filling a box, sphere, capsule or cylinder, or points over a mesh's triangles (a moving
/// mesh is its convex hull to Bullet; its own triangles are what a person recognises).
/// A plane gives none. At most 64 points along a side or a triangle's edge.
std::vector<btVector3> bodyPoints(const Body& b, float& spacing) {
  std::vector<btVector3> points;
  btVector3 lo, hi;
  b.shape->getAabb(btTransform::getIdentity(), lo, hi);
  const btVector3 extent = hi - lo;
  if (!b.mesh.indices.empty()) {
    spacing = extent[extent.maxAxis()] / 32;
    for (size_t t = 0; t < b.mesh.triangleCount(); ++t) {
      btVector3 v[3];
      for (int k = 0; k < 3; ++k) {
        const Vec3f& p = b.mesh.vertices[b.mesh.indices[3 * t + k]];
        v[k] = btVector3(p.x, p.y, p.z);
      }
      const float edge = std::max({(v[1] - v[0]).length(), (v[2] - v[1]).length(), (v[0] - v[2]).length()});
      const int n = (int)std::clamp(std::ceil(edge / spacing), 1.f, 64.f);
      for (int i = 0; i <= n; ++i)
        for (int j = 0; i + j <= n; ++j) points.push_back(v[0] + (v[1] - v[0]) * ((float)i / n) + (v[2] - v[0]) * ((float)j / n));
    }
    return points;
  }
  if (b.shape->getShapeType() == STATIC_PLANE_PROXYTYPE) return points;
  // as fine as a twelfth of the longest side and half the shortest, so a thin shape gets a layer
  const float step = std::min(extent[extent.maxAxis()] / 12, extent[extent.minAxis()] / 2);
  int n[3];
  for (int a = 0; a < 3; ++a) n[a] = (int)std::clamp(std::round(extent[a] / step), 1.f, 64.f);
  const btVector3 cell(extent.x() / n[0], extent.y() / n[1], extent.z() / n[2]);
  spacing = cell[cell.maxAxis()];
  for (int i = 0; i < n[0]; ++i)
    for (int j = 0; j < n[1]; ++j)
      for (int k = 0; k < n[2]; ++k) {
        const btVector3 p = lo + cell * btVector3(i + 0.5f, j + 0.5f, k + 0.5f);
        if (inside(b.shape.get(), p)) points.push_back(p);
      }
  return points;
}

/// What is drawn besides the tissue: needles' arcs and threads as polylines, slicers' blades
/// and coloured bodies (filled, or over their mesh's triangles) as points; `radius` is the splat's in the picture.
struct ToolDrawing {
  std::vector<Vec3f> points;
  bool polyline = false;
  io::Rgb colour;
  float radius = 0.f;
};

std::vector<ToolDrawing> toolDrawings(const LoadedScene::Impl& s, float wire) {
  std::vector<ToolDrawing> out;
  for (const auto& b : s.bodies) {  // a body given a colour: points filling it, or over its mesh
    if (!b->color) continue;
    float spacing = 0.f;
    const std::vector<btVector3> local = bodyPoints(*b, spacing);
    const btTransform t = b->body->getCenterOfMassTransform();
    ToolDrawing d{{}, false, *b->color, 0.6f * spacing};
    d.points.reserve(local.size());
    for (const btVector3& p : local) d.points.push_back(vec(t * p));
    if (!d.points.empty()) out.push_back(std::move(d));
  }
  for (const Needle& n : s.needles) {
    const btTransform frame = n.body->body->getCenterOfMassTransform() *
                              btTransform(btQuaternion(n.arc.pose.rotation.x, n.arc.pose.rotation.y,
                                                       n.arc.pose.rotation.z, n.arc.pose.rotation.w),
                                          btVector3(n.arc.pose.position.x, n.arc.pose.position.y, n.arc.pose.position.z));
    ToolDrawing d{{}, true, {90, 95, 120}, 1.25f * wire};  // steel a little thicker than the thread
    for (int i = 0; i <= 32; ++i) {
      const float a = n.arc.startAngle + (n.arc.endAngle - n.arc.startAngle) * i / 32;
      d.points.push_back(vec(frame * btVector3(n.arc.radius * std::cos(a), n.arc.radius * std::sin(a), 0)));
    }
    out.push_back(std::move(d));
  }
  for (const Slicer& sl : s.slicers) {  // the blade's face, as the tissue saw it
    const ShapeState blade = s.scene->slicerState(sl.id);
    const QuadSlicerDesc& q = sl.blade;
    const btTransform frame(btQuaternion(blade.pose.rotation.x, blade.pose.rotation.y, blade.pose.rotation.z,
                                         blade.pose.rotation.w),
                            btVector3(blade.pose.position.x, blade.pose.position.y, blade.pose.position.z));
    ToolDrawing d{{}, false, {170, 175, 190}, std::min(q.halfLength / 15.f, q.width / 40.f)};
    for (int i = 0; i <= 30; ++i)  // as the cutting demo draws it: 31 x 41 points
      for (int j = 0; j <= 40; ++j)
        d.points.push_back(vec(frame * btVector3(q.halfLength * (i / 15.f - 1.f), q.width * j / 40.f, 0)));
    out.push_back(std::move(d));
  }
  for (const Thread& t : s.threads) {
    ToolDrawing d{{}, true, {40, 90, 200}, wire};
    for (const btVector3& p : threadPoints(t.multibody)) d.points.push_back(vec(p));
    // a fixed base is the knot: a dark bead where the thread starts, large enough to see
    if (t.multibody->hasFixedBase() && !d.points.empty()) out.push_back({{d.points.front()}, false, {25, 25, 30}, 5.f * wire});
    out.push_back(std::move(d));
  }
  return out;
}

float splatRadius(const LoadedScene::Impl& s) {
  return s.output.particleRadius > 0.f ? s.output.particleRadius : 0.3f * s.scene->settings().dx;
}

float wireRadius(const LoadedScene::Impl& s) {
  return s.output.wireRadius > 0.f ? s.output.wireRadius : 0.2f * splatRadius(s);
}

}  // namespace

bool LoadedScene::pngDue() const {
  const int every = impl_->output.pngEvery;
  return every > 0 && (frame() % every == 0 || frame() == frameCount());
}

bool LoadedScene::plyDue() const { return impl_->output.ply && pngDue(); }

void LoadedScene::writePng(const std::string& path) const {
  const Impl& s = *impl_;
  const Output& o = s.output;
  io::SplatRenderer renderer(o.camera);
  if (o.ground) renderer.setGround(o.ground->first, o.ground->second);
  const float radius = splatRadius(s);
  std::vector<Vec3f> x, shown;
  for (const Object& obj : s.objects) {
    s.scene->readPositions(obj.id, x);
    shown.clear();
    for (const Vec3f& p : x)
      if (!o.cutaway || dot(o.cutaway->first, p) <= o.cutaway->second) shown.push_back(p);
    renderer.addParticles(shown, radius, obj.color);
  }
  const float wire = wireRadius(s);
  for (const ToolDrawing& d : toolDrawings(s, wire)) {
    if (!d.polyline) {
      renderer.addParticles(d.points, d.radius, d.colour);
      continue;
    }
    std::vector<btVector3> line;
    for (const Vec3f& p : d.points) line.push_back(btVector3(p.x, p.y, p.z));
    std::vector<Vec3f> splats;
    addPolyline(line, wire, splats);
    renderer.addParticles(splats, d.radius, d.colour);
  }
  renderer.writePng(path);
}

void LoadedScene::writePly(const std::string& tissuePath, const std::string& toolsPath) const {
  const Impl& s = *impl_;
  io::PlyFrame tissue;  // every particle, in its object's order and colour (no cutaway)
  std::vector<Vec3f> x;
  for (const Object& obj : s.objects) {
    s.scene->readPositions(obj.id, x);
    tissue.addPoints(x, obj.color);
  }
  io::writePly(tissuePath, tissue);
  if (toolsPath.empty()) return;
  io::PlyFrame tools;
  for (const ToolDrawing& d : toolDrawings(s, wireRadius(s)))
    d.polyline ? tools.addPolyline(d.points, d.colour) : tools.addPoints(d.points, d.colour);
  if (!tools.points.empty()) io::writePly(toolsPath, tools);  // an empty PLY is no help to a viewer
}

std::string LoadedScene::csvHeader() const {
  std::string h = "time_s";
  for (const Output::Column& c : impl_->output.columns)
    for (const char* axis : {"_x", "_y", "_z"}) h += "," + c.name + axis;
  return h;
}

std::string LoadedScene::csvRow() const {
  const Impl& s = *impl_;
  std::ostringstream row;
  row.precision(9);
  row << s.scene->time();
  const int ticks = std::max(1, (int)std::lround(s.output.frameTime / s.tick));
  for (const Output::Column& c : s.output.columns) {
    Vec3f v{0.f, 0.f, 0.f};
    switch (c.kind) {
      case Output::Column::Position: v = vec(c.body->body->getCenterOfMassPosition()); break;
      case Output::Column::Velocity: v = vec(c.body->body->getLinearVelocity()); break;
      case Output::Column::Force: v = vec(c.body->frameImpulse / (ticks * s.tick)); break;  // the frame's mean
      case Output::Column::CenterOfMass: {
        const ObjectSummary m = s.scene->summary(c.object);
        v = {(float)m.centerOfMass[0], (float)m.centerOfMass[1], (float)m.centerOfMass[2]};
        break;
      }
    }
    row << "," << v.x << "," << v.y << "," << v.z;
  }
  return row.str();
}

}  // namespace mpm::bullet
