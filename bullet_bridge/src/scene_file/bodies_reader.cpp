// "bodies": Bullet rigid bodies with their shape, mass, pose, friction, collision filter,
// how they touch the tissue (CouplingOptions) and an optional scripted motion.
#include "mpm_bullet/mesh_import.h"
#include "scene_file/readers.h"

namespace mpm::bullet::scene_file {

namespace {

btVector3 bt(Vec3f v) { return btVector3(v.x, v.y, v.z); }

float positive(Node& n, const char* key) {
  float v = 0.f;
  n.readRequired(key, v);
  if (!(v > 0.f)) fail(n.at(key), n.require(key), "must be > 0");
  return v;
}

/// The body's Bullet shape; a mesh shape's triangles also go to `mesh`, for the pictures.
std::unique_ptr<btCollisionShape> readShape(Node n, float mass, const LoadedScene::Impl& s, TriangleMesh& mesh) {
  std::string type;
  n.readRequired("type", type);
  std::unique_ptr<btCollisionShape> shape;
  if (type == "box") {
    Vec3f h;
    n.readRequired("halfExtents", h);
    if (!(h.x > 0.f && h.y > 0.f && h.z > 0.f)) fail(n.at("halfExtents"), n.require("halfExtents"), "every component must be > 0");
    shape = std::make_unique<btBoxShape>(bt(h));
  } else if (type == "sphere") {
    shape = std::make_unique<btSphereShape>(positive(n, "radius"));
  } else if (type == "capsule") {  // along local y, as mpm::Geometry's halfHeight
    const float r = positive(n, "radius");
    shape = std::make_unique<btCapsuleShape>(r, 2.f * positive(n, "halfHeight"));
  } else if (type == "cylinder") {
    const float r = positive(n, "radius");
    shape = std::make_unique<btCylinderShape>(btVector3(r, positive(n, "halfHeight"), r));
  } else if (type == "plane") {  // the solid below n.x = constant
    if (mass != 0.f) fail(n.at("type"), type, "a plane must be static (mass 0)");
    Vec3f normal{0.f, 1.f, 0.f};
    float constant = 0.f;
    n.read("normal", normal);
    n.read("constant", constant);
    if (!(dot(normal, normal) > 0.f)) fail(n.at("normal"), n.require("normal"), "must not be zero");
    shape = std::make_unique<btStaticPlaneShape>(bt(normal).normalized(), constant);
  } else if (type == "mesh") {  // static: the triangles themselves; moving: their convex hull
    const std::string file = resolveFile(s, n.require("file"), n.at("file"));
    float scale = 1.f;
    n.read("scale", scale);
    if (!(scale > 0.f)) fail(n.at("scale"), scale, "must be > 0");
    try {
      mesh = loadTriangleMesh(file, scale);
      shape = mass == 0.f ? makeBvhTriangleMeshShape(mesh) : makeConvexHullShape(mesh);
    } catch (const Error& e) {
      throw InvalidArgument(n.at("file"), show(n.require("file")), e.what());
    }
  } else {
    fail(n.at("type"), type, "must be one of box, sphere, capsule, cylinder, plane, mesh");
  }
  n.finish();
  return shape;
}

Keyframes readKeyframes(Node& n) {
  Keyframes k;
  std::string ease = "smoothstep";
  if (n.read("ease", ease) && ease != "smoothstep" && ease != "linear")
    fail(n.at("ease"), ease, "must be one of smoothstep, linear");
  k.smoothstep = ease == "smoothstep";
  const Json& frames = n.array("keyframes");
  if (frames.empty()) failMissing(n.at("keyframes"), "at least one keyframe");
  for (size_t i = 0; i < frames.size(); ++i) {
    Node f(frames[i], element(n.at("keyframes"), i));
    Keyframe kf;
    f.readRequired("time", kf.time);
    if (!(kf.time >= 0) || (i > 0 && !(kf.time > k.frames.back().time)))
      fail(f.at("time"), kf.time, "must be >= 0 and after the previous keyframe's");
    f.readRequired("position", kf.position);
    if (const Json* r = f.get("rotation")) {
      Node rn(*r, f.at("rotation"));
      rn.readRequired("axis", kf.axis);
      rn.readRequired("angle", kf.angle);
      rn.finish();
      if (!(dot(kf.axis, kf.axis) > 0.f)) fail(rn.at("axis"), (*r)["axis"], "must not be zero");
    }
    std::string stretch;
    if (f.read("ease", stretch)) {
      if (stretch != "smoothstep" && stretch != "linear") fail(f.at("ease"), stretch, "must be one of smoothstep, linear");
      kf.smoothstep = stretch == "smoothstep";
    }
    f.finish();
    k.frames.push_back(kf);
  }
  return k;
}

void readBody(Node n, LoadedScene::Impl& s) {
  auto b = std::make_unique<Body>();
  n.readRequired("name", b->name);
  if (s.findBody(b->name)) fail(n.at("name"), b->name, "another body has this name");
  float mass = 0.f;
  n.read("mass", mass);
  if (!(mass >= 0.f)) fail(n.at("mass"), n.require("mass"), "must be >= 0 (0: static or kinematic)");
  b->shape = readShape(n.object("shape"), mass, s, b->mesh);

  // the motion: kinematic (a motion state Bullet asks) or driven (NeedleDriver's forces)
  std::string mode;
  std::optional<NeedleDriveLimits> limits;
  if (n.has("motion")) {
    Node m = n.object("motion");
    m.readRequired("mode", mode);
    if (mode != "kinematic" && mode != "driver") fail(m.at("mode"), mode, "must be one of kinematic, driver");
    if (mode == "kinematic" && mass != 0.f) fail(m.at("mode"), mode, "a kinematic body has mass 0");
    b->script = readKeyframes(m);
    if (m.has("limits")) {
      if (mode != "driver") fail(m.at("limits"), m.require("limits"), "only with \"mode\": \"driver\"");
      Node l = m.object("limits");
      limits.emplace();
      l.read("maxForce", limits->maxForce);
      l.read("maxTorque", limits->maxTorque);
      l.read("timeConstant", limits->timeConstant);
      l.finish();
    } else if (mode == "driver") {
      limits.emplace();
    }
    m.finish();
    if (n.has("pose")) fail(n.at("pose"), n.require("pose"), "a body with a motion starts at its first keyframe's pose");
  }
  Pose pose;
  n.read("pose", pose);
  btTransform start(btQuaternion(pose.rotation.x, pose.rotation.y, pose.rotation.z, pose.rotation.w), bt(pose.position));
  if (b->script) start = b->script->pose(0);

  btVector3 inertia(0, 0, 0);
  Vec3f given;
  if (n.read("inertia", given)) {
    if (!(given.x > 0.f && given.y > 0.f && given.z > 0.f)) fail(n.at("inertia"), n.require("inertia"), "every component must be > 0");
    inertia = bt(given);
  } else if (mass > 0.f) {
    b->shape->calculateLocalInertia(mass, inertia);
  }
  btMotionState* state = nullptr;
  if (mode == "kinematic") {
    auto k = std::make_unique<KinematicScript>();
    k->keys = &*b->script;
    k->clock = &s.bulletTime;
    k->tick = s.tick;
    state = k.get();
    b->motionState = std::move(k);
  }
  btRigidBody::btRigidBodyConstructionInfo info(mass, state, b->shape.get(), inertia);
  info.m_startWorldTransform = start;
  n.read("friction", info.m_friction);
  b->body = std::make_unique<btRigidBody>(info);
  Vec3f v{0.f, 0.f, 0.f}, w{0.f, 0.f, 0.f};
  if (n.read("linearVelocity", v)) b->body->setLinearVelocity(bt(v));
  if (n.read("angularVelocity", w)) b->body->setAngularVelocity(bt(w));
  if (mode == "kinematic") {
    b->body->setCollisionFlags(b->body->getCollisionFlags() | btCollisionObject::CF_KINEMATIC_OBJECT);
    b->body->setActivationState(DISABLE_DEACTIVATION);
  }
  bool contactResponse = true;
  if (n.read("contactResponse", contactResponse) && !contactResponse)
    b->body->setCollisionFlags(b->body->getCollisionFlags() | btCollisionObject::CF_NO_CONTACT_RESPONSE);
  int group = btBroadphaseProxy::DefaultFilter, mask = btBroadphaseProxy::AllFilter;
  const bool filtered = n.read("collisionGroup", group) | n.read("collisionMask", mask);
  if (filtered) s.world->addRigidBody(b->body.get(), group, mask);
  else s.world->addRigidBody(b->body.get());
  Body* body = b.get();
  s.bodies.push_back(std::move(b));  // owned from here on: released with the scene on any error below

  if (limits) {
    try {
      body->driver = std::make_unique<NeedleDriver>(body->body.get(), *limits);
    } catch (const InvalidArgument& e) {
      rethrowAt(e, "NeedleDriveLimits", n.at("motion") + ".limits");
    }
  }
  if (const Json* c = n.get("color")) body->color = readColor(*c, n.at("color"));
  body->coupled = true;
  n.read("coupled", body->coupled);
  CouplingOptions options;
  if (n.has("coupling")) {
    if (!body->coupled) fail(n.at("coupling"), n.require("coupling"), "only for a coupled body");
    Node c = n.object("coupling");
    if (c.has("contact")) {
      Node contact = c.object("contact");
      contact.read("mode", options.contact.mode);
      float friction;
      if (contact.read("friction", friction)) options.contact.friction = friction;
      contact.read("drag", options.contact.drag);
      contact.read("band", options.contact.band);
      contact.finish();
    }
    c.read("sdfCellSize", options.sdfCellSize);
    c.finish();
  }
  n.finish();
  if (body->coupled) {
    try {
      s.coupler->addRigidBody(body->body.get(), options);
    } catch (const InvalidArgument& e) {
      rethrowAt(e, "CouplingOptions", n.at("coupling"));
    }
  }
}

}  // namespace

void readBodies(const Json& bodies, LoadedScene::Impl& s) {
  for (size_t i = 0; i < bodies.size(); ++i) readBody(Node(bodies[i], element("bodies", i)), s);
}

}  // namespace mpm::bullet::scene_file
