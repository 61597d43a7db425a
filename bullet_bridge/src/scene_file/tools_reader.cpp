// "slicers", "needles", "threads": blades and needles on named bodies, suture threads with
// their pins. Key names are the C++ descriptions' (QuadSlicerDesc, ArcDesc,
// SutureThreadDesc, ThreadCoupling), so the library's errors are renamed to key paths.
#include <algorithm>
#include <cmath>

#include "scene_file/readers.h"

namespace mpm::bullet::scene_file {

namespace {

btVector3 bt(Vec3f v) { return btVector3(v.x, v.y, v.z); }

Body* readBodyName(Node& n, const LoadedScene::Impl& s) {
  std::string name;
  n.readRequired("body", name);
  Body* b = s.findBody(name);
  if (!b) fail(n.at("body"), name, "no body of this name");
  return b;
}

/// Turns each joint of `thread` by `bend` (a world-frame rotation), so that it starts with
/// slack: a flat arc instead of a straight line.
void bendJoints(btMultiBody* thread, const Quat& bend) {
  const btQuaternion toBase = thread->getWorldToBaseRot();  // world to the links' frame
  const btVector3 axis = quatRotate(toBase, btVector3(bend.x, bend.y, bend.z));
  if (axis.length2() == 0) return;
  const btQuaternion q(axis.normalized(), 2.f * std::acos(std::clamp(bend.w, -1.f, 1.f)));
  for (int i = 0; i < thread->getNumLinks(); ++i) {
    const btScalar joint[4] = {q.x(), q.y(), q.z(), q.w()};
    thread->setJointPosMultiDof(i, joint);
  }
  btAlignedObjectArray<btQuaternion> rot;
  btAlignedObjectArray<btVector3> pos;
  thread->forwardKinematics(rot, pos);
  thread->updateCollisionObjectWorldTransforms(rot, pos);
}

struct Pin {
  int point = 0;
  Body* body = nullptr;  ///< null: the world
  std::optional<Vec3f> pivot;
  std::string path;
};

void readThread(Node n, LoadedScene::Impl& s, size_t index) {
  Thread t;
  t.name = "thread" + std::to_string(index);
  n.read("name", t.name);
  for (const Thread& other : s.threads)
    if (other.name == t.name) fail(n.at("name"), t.name, "another thread has this name");
  SutureThreadDesc d;
  n.read("length", d.length);
  n.read("segments", d.segments);
  n.read("radius", d.radius);
  n.read("linearDensity", d.linearDensity);
  n.read("damping", d.damping);
  n.read("youngsModulus", d.youngsModulus);
  Vec3f v;
  const bool hasStart = n.read("start", v);
  d.start = bt(v);
  if (n.read("direction", v)) d.direction = bt(v);
  n.read("fixedBase", d.fixedBase);
  n.read("friction", d.friction);
  n.read("maxTension", d.maxTension);
  d.tick = s.tick;  // the world's, unless the thread names another
  n.read("tick", d.tick);
  n.read("collisionGroup", d.collisionGroup);
  n.read("collisionMask", d.collisionMask);
  // laid along a path: its points, and start and direction from them
  std::vector<btVector3> laid;
  if (n.has("path")) {
    Node pn = n.object("path");
    if (hasStart || n.has("direction")) fail(n.at("path"), n.require("path"), "not with start or direction");
    const Json& cornerList = pn.array("corners");
    std::vector<btVector3> corners;
    for (size_t k = 0; k < cornerList.size(); ++k) {
      Vec3f c;
      parse(cornerList[k], element(pn.at("corners"), k), c);
      corners.push_back(bt(c));
    }
    std::string from = "first";
    if (pn.read("measuredFrom", from) && from != "first" && from != "last")
      fail(pn.at("measuredFrom"), from, "must be one of first, last");
    pn.finish();
    if (from == "last") std::reverse(corners.begin(), corners.end());
    // the thread's own checks come later: a count it refuses must not size the path first
    if (d.segments < 2 || d.segments > 100000) fail(n.at("segments"), d.segments, "must lie in [2, 100000] to lay a path");
    try {
      laid = threadPointsAlong(corners, d.length / (float)std::max(d.segments, 1), d.segments);
    } catch (const InvalidArgument& e) {
      rethrowAt(e, "threadPointsAlong", pn.path());
    }
    if (from == "last") std::reverse(laid.begin(), laid.end());  // point 0 where the length ran out
    d.start = laid[0];
    d.direction = laid[1] - laid[0];
  }
  std::optional<Quat> bend;
  if (n.has("bend")) {
    Quat q;
    n.read("bend", q);
    bend = q;
  }
  ThreadCoupling coupling;
  if (n.has("coupling")) {
    Node c = n.object("coupling");
    c.read("radius", coupling.radius);
    c.read("friction", coupling.friction);
    c.read("drag", coupling.drag);
    c.read("dynamic", coupling.dynamic);
    c.read("addedMass", coupling.addedMass);
    c.finish();
  }
  std::vector<Pin> pins;
  const Json& pinList = n.array("pins");
  for (size_t k = 0; k < pinList.size(); ++k) {
    Node p(pinList[k], element(n.at("pins"), k));
    Pin pin;
    pin.path = p.path();
    p.readRequired("point", pin.point);
    if (p.has("body")) pin.body = readBodyName(p, s);
    Vec3f pivot;
    if (p.read("pivot", pivot)) pin.pivot = pivot;
    p.finish();
    pins.push_back(pin);
  }
  n.finish();
  // no start given: the point pinned first to a body, where the pin holds it
  if (!hasStart && laid.empty()) {
    const Pin* eye = nullptr;
    for (const Pin& p : pins)
      if (p.point == 0 && p.body && p.pivot) eye = &p;
    if (!eye) failMissing(n.at("start"), "required unless a pin holds point 0 to a body at a pivot");
    d.start = eye->body->body->getCenterOfMassTransform() * bt(*eye->pivot);
  }

  try {
    t.multibody = makeSutureThread(s.world.get(), d);
  } catch (const InvalidArgument& e) {
    rethrowAt(e, "SutureThreadDesc", n.path());
  }
  s.threads.push_back(t);  // owned from here on
  if (bend) bendJoints(t.multibody, *bend);
  if (!laid.empty()) layThreadAlong(t.multibody, laid);
  for (const Pin& p : pins) {
    // no pivot: the point is held where it is now
    btVector3 pivot = p.pivot ? bt(*p.pivot) : btVector3(0, 0, 0);
    if (!p.pivot && p.point >= 0 && p.point <= d.segments) {
      pivot = threadPoints(t.multibody)[p.point];
      if (p.body) pivot = p.body->body->getCenterOfMassTransform().inverse() * pivot;
    }
    try {
      s.threads.back().pins.push_back(
          {p.point, pinThreadPoint(s.world.get(), t.multibody, p.point, p.body ? p.body->body.get() : nullptr, pivot)});
    } catch (const InvalidArgument& e) {
      rethrowAt(e, "pinThreadPoint ", p.path + ".");
    }
  }
  try {
    s.coupler->addThread(t.multibody, coupling);
  } catch (const InvalidArgument& e) {
    rethrowAt(e, "ThreadCoupling", n.at("coupling"));
  }
}

}  // namespace

void readSlicers(const Json& slicers, LoadedScene::Impl& s) {
  for (size_t i = 0; i < slicers.size(); ++i) {
    Node n(slicers[i], element("slicers", i));
    Body* body = readBodyName(n, s);
    QuadSlicerDesc d;
    n.read("halfLength", d.halfLength);
    n.read("width", d.width);
    n.read("spineRadius", d.spineRadius);
    n.read("halfThickness", d.halfThickness);
    n.read("friction", d.friction);
    n.read("pose", d.pose);
    n.finish();
    try {
      s.slicers.push_back({body, d, s.coupler->addSlicer(body->body.get(), d)});
    } catch (const InvalidArgument& e) {
      rethrowAt(e, "QuadSlicerDesc", n.path());
    }
  }
}

void readNeedles(const Json& needles, LoadedScene::Impl& s) {
  for (size_t i = 0; i < needles.size(); ++i) {
    Node n(needles[i], element("needles", i));
    Needle needle;
    needle.body = readBodyName(n, s);
    ArcDesc& d = needle.arc;
    n.read("radius", d.radius);
    n.read("startAngle", d.startAngle);
    n.read("endAngle", d.endAngle);
    n.read("wireRadius", d.wireRadius);
    n.read("friction", d.friction);
    n.read("punctureForce", d.punctureForce);
    n.read("pose", d.pose);
    n.finish();
    try {
      needle.curve = s.coupler->addNeedle(needle.body->body.get(), d);
    } catch (const InvalidArgument& e) {
      rethrowAt(e, "ArcDesc", n.path());
    }
    s.needles.push_back(needle);
  }
}

void readThreads(const Json& threads, LoadedScene::Impl& s) {
  for (size_t i = 0; i < threads.size(); ++i) readThread(Node(threads[i], element("threads", i)), s, i);
}

}  // namespace mpm::bullet::scene_file
