// Scene: the public calls, tied together by SceneImpl. Each concern has its own file under
// scene/: the handle tables (slot_table.h), particle seeding, the substep policy, the
// energy account, the shapes' exchange with the backend and the step worker. The particle
// and grid work is the backend's.
#include "mpm/scene.h"

#include "scene/scene_impl.h"

namespace mpm {

Scene::Scene(const SceneSettings& settings) : impl_(std::make_unique<SceneImpl>(settings)) {}
Scene::~Scene() = default;
Scene::Scene(Scene&&) noexcept = default;
Scene& Scene::operator=(Scene&&) noexcept = default;

// Every call below holds the scene for as long as it reads (impl_->reading) or changes it
// (impl_->changing): refused with StepInProgress while an advance runs, from any thread.
ParticleObjectId Scene::addParticleObject(const ParticleObjectDesc& d) {
  const auto held = impl_->changing("addParticleObject");
  return impl_->add(d);
}
void Scene::removeParticleObject(ParticleObjectId id) {
  const auto held = impl_->changing("removeParticleObject");
  impl_->remove(id);
}
// the handle tables do not change during an advance: isValid answers then too
bool Scene::isValid(ParticleObjectId id) const {
  const SceneImpl::Reading held(impl_->gate);
  return impl_->objects.isValid(id);
}
std::vector<ParticleObjectId> Scene::particleObjects() const {
  const SceneImpl::Reading held(impl_->gate);
  return impl_->objects.liveIds();
}
void Scene::advance(float dt) { impl_->advance(dt); }
StepReport Scene::fetchResults() { return impl_->fetch(); }
void Scene::cancel() { impl_->cancelRequested.store(true); }
ShapeId Scene::addShape(const ShapeDesc& d) {
  const auto held = impl_->changing("addShape");
  return impl_->addShape(d);
}
void Scene::removeShape(ShapeId id) {
  const auto held = impl_->changing("removeShape");
  impl_->removeShape(id);
}
bool Scene::isValid(ShapeId id) const {
  const SceneImpl::Reading held(impl_->gate);
  return impl_->shapes.isValid(id);
}
void Scene::setShapeState(ShapeId id, const ShapeState& s) {
  const auto held = impl_->changing("setShapeState");
  impl_->setMotion(impl_->shapes, id, s, "setShapeState");
}
ShapeState Scene::shapeState(ShapeId id) const {
  const auto held = impl_->reading("shapeState");
  return impl_->idleRecord(impl_->shapes, id, "shapeState").state;
}
ShapeImpulse Scene::shapeImpulse(ShapeId id) const {
  const auto held = impl_->reading("shapeImpulse");
  return impl_->idleRecord(impl_->shapes, id, "shapeImpulse").lastImpulse;
}
SlicerId Scene::addSlicer(const QuadSlicerDesc& d) {
  const auto held = impl_->changing("addSlicer");
  return impl_->addSlicer(d);
}
SlicerId Scene::addSlicer(const MeshSlicerDesc& d) {
  const auto held = impl_->changing("addSlicer");
  return impl_->addSlicer(d);
}
void Scene::removeSlicer(SlicerId id) {
  const auto held = impl_->changing("removeSlicer");
  impl_->idleRecord(impl_->slicers, id, "removeSlicer");
  impl_->slicers.remove(id);  // its cuts stay in the particles
}
bool Scene::isValid(SlicerId id) const {
  const SceneImpl::Reading held(impl_->gate);
  return impl_->slicers.isValid(id);
}
void Scene::setSlicerState(SlicerId id, const ShapeState& s) {
  const auto held = impl_->changing("setSlicerState");
  impl_->setMotion(impl_->slicers, id, s, "setSlicerState");
}
ShapeState Scene::slicerState(SlicerId id) const {
  const auto held = impl_->reading("slicerState");
  return impl_->idleRecord(impl_->slicers, id, "slicerState").state;
}
ShapeImpulse Scene::slicerImpulse(SlicerId id) const {
  const auto held = impl_->reading("slicerImpulse");
  return impl_->idleRecord(impl_->slicers, id, "slicerImpulse").lastImpulse;
}
void Scene::setStepThreads(int threads) {
  const auto held = impl_->changing("setStepThreads");
  impl_->backend->setCpuThreads(threads > 0 ? threads : impl_->settings.cpuThreads);
}
bool Scene::stepping() const { return impl_->stepping.load(); }
StepReport Scene::step(float dt) { return impl_->step(dt); }
float Scene::maxSubstep() {
  const auto held = impl_->reading("maxSubstep");
  return impl_->substepBounds().maxSubstep();
}
double Scene::time() const {
  const auto held = impl_->reading("time");
  return impl_->time;
}
Backend Scene::backend() const { return impl_->resolved; }
const SceneSettings& Scene::settings() const { return impl_->settings; }
size_t Scene::particleCount() const {
  const auto held = impl_->reading("particleCount");
  return impl_->backend->particleCount();
}
size_t Scene::particleCount(ParticleObjectId id) const {
  const SceneImpl::Reading held(impl_->gate);  // an object's count does not change during an advance
  return impl_->objects.lookup(id, "particleCount").particles;
}

namespace {
/// Gathers one object's particles in their stable per-object order.
template <class T, class Pick>
void gatherObject(const SceneImpl& s, ParticleObjectId id, const char* call, Pick pick,
                  std::vector<T>& out) {
  const auto held = s.reading(call);
  const ObjectRecord& rec = s.objects.lookup(id, call);
  HostParticles all;
  s.backend->download(all);
  out.resize(rec.particles);
  for (size_t i = 0; i < all.size(); ++i)
    if (all.object[i] == id.index) out[all.local[i]] = pick(all, i);
}
}  // namespace

void Scene::readPositions(ParticleObjectId id, std::vector<Vec3f>& out) const {
  gatherObject(*impl_, id, "readPositions", [](const HostParticles& a, size_t i) { return a.x[i]; }, out);
}
void Scene::readVelocities(ParticleObjectId id, std::vector<Vec3f>& out) const {
  gatherObject(*impl_, id, "readVelocities", [](const HostParticles& a, size_t i) { return a.v[i]; }, out);
}
void Scene::readDeformationGradients(ParticleObjectId id, std::vector<Mat3f>& out) const {
  gatherObject(*impl_, id, "readDeformationGradients",
               [](const HostParticles& a, size_t i) { return a.F[i]; }, out);
}

ObjectSummary Scene::summary(ParticleObjectId id) const {
  const auto held = impl_->reading("summary");
  impl_->objects.lookup(id, "summary");
  HostParticles all;
  impl_->backend->download(all);
  ObjectSummary s;
  // APIC carries spin in C: a particle's angular momentum about its own position is
  // m D eps : C^T with D = dx^2 / 4 for quadratic B-splines (Jiang et al. 2015).
  const double D =
      solverTraits(impl_->settings.solver).affine ? 0.25 * (double)impl_->settings.dx * impl_->settings.dx : 0.0;
  double lx = 0, ly = 0, lz = 0;
  for (size_t i = 0; i < all.size(); ++i) {
    if (all.object[i] != id.index) continue;
    const double m = all.mass[i];
    const Vec3f x = all.x[i], v = all.v[i];
    const Mat3f& C = all.C[i];
    s.particles++;
    s.mass += m;
    s.centerOfMass[0] += m * x.x; s.centerOfMass[1] += m * x.y; s.centerOfMass[2] += m * x.z;
    s.momentum[0] += m * v.x; s.momentum[1] += m * v.y; s.momentum[2] += m * v.z;
    lx += m * ((double)x.y * v.z - (double)x.z * v.y) + m * D * (C.m[2][1] - C.m[1][2]);
    ly += m * ((double)x.z * v.x - (double)x.x * v.z) + m * D * (C.m[0][2] - C.m[2][0]);
    lz += m * ((double)x.x * v.y - (double)x.y * v.x) + m * D * (C.m[1][0] - C.m[0][1]);
    s.kineticEnergy += 0.5 * m * ((double)v.x * v.x + (double)v.y * v.y + (double)v.z * v.z);
  }
  for (double& c : s.centerOfMass) c /= s.mass;
  // about the centre of mass: L - c x p
  const double* c = s.centerOfMass;
  const double* p = s.momentum;
  s.angularMomentum[0] = lx - (c[1] * p[2] - c[2] * p[1]);
  s.angularMomentum[1] = ly - (c[2] * p[0] - c[0] * p[2]);
  s.angularMomentum[2] = lz - (c[0] * p[1] - c[1] * p[0]);
  return s;
}

void Scene::save(const std::string& path, const std::vector<uint8_t>& attachment) const {
  const auto held = impl_->reading("save");
  checkpoint::writeFileAtomically(path, impl_->checkpoint(attachment));
}
std::vector<uint8_t> Scene::saveToMemory(const std::vector<uint8_t>& attachment) const {
  const auto held = impl_->reading("saveToMemory");
  return impl_->checkpoint(attachment);
}
std::vector<uint8_t> Scene::load(const std::string& path) {
  const auto held = impl_->changing("load");
  return impl_->load(checkpoint::readFile(path));
}
std::vector<uint8_t> Scene::loadFromMemory(const std::vector<uint8_t>& bytes) {
  const auto held = impl_->changing("loadFromMemory");
  return impl_->load(bytes);
}
std::vector<uint8_t> Scene::attachmentOf(const std::vector<uint8_t>& bytes) const {
  const auto held = impl_->reading("attachmentOf");
  return impl_->read(bytes).attachment;
}

// the worker thread writes these during a step: read only between steps, like the rest
StageTimings Scene::timings() const {
  const auto held = impl_->reading("timings");
  return impl_->backend->timings;
}
void Scene::resetTimings() {
  const auto held = impl_->changing("resetTimings");
  impl_->backend->timings = StageTimings{};
}
size_t Scene::memoryBytes() const {
  const auto held = impl_->reading("memoryBytes");
  return impl_->backend->memoryBytes();
}

}  // namespace mpm

namespace mpm {

CurveId Scene::addCurve(const ArcDesc& d) {
  const auto held = impl_->changing("addCurve");
  return impl_->addCurve(d);
}
CurveId Scene::addCurve(const LineSegmentsDesc& d) {
  const auto held = impl_->changing("addCurve");
  return impl_->addCurve(d);
}
void Scene::removeCurve(CurveId id) {
  const auto held = impl_->changing("removeCurve");
  impl_->idleRecord(impl_->curves, id, "removeCurve");
  impl_->curves.remove(id);
}
bool Scene::isValid(CurveId id) const {
  const SceneImpl::Reading held(impl_->gate);
  return impl_->curves.isValid(id);
}
void Scene::setCurveState(CurveId id, const ShapeState& s) {
  const auto held = impl_->changing("setCurveState");
  CurveRecord& c = impl_->curveOfKind(id, true, "setCurveState");
  validateShapeState(s);
  checkSpeed("ShapeState", c, s, impl_->settings);
  c.state = s;
}
ShapeState Scene::curveState(CurveId id) const {
  const auto held = impl_->reading("curveState");
  return impl_->curveOfKind(id, true, "curveState").state;
}
void Scene::setCurvePoints(CurveId id, const std::vector<Vec3f>& points, const std::vector<Vec3f>& velocities) {
  const auto held = impl_->changing("setCurvePoints");
  CurveRecord& c = impl_->curveOfKind(id, false, "setCurvePoints");
  validateCurvePoints(points, velocities, c.thread.points.size());
  validateThreadSpeeds(velocities, SubstepBounds::maxShapeSpeed(impl_->settings));
  c.thread.points = points;
  c.thread.velocities = velocities;
}
namespace {
/// A curve's impulse summed over its bodies: a needle's are both about its frame origin, a
/// thread's segments about their midpoints, moved to its first point.
ShapeImpulse summedImpulse(const CurveRecord& c) {
  ShapeImpulse sum;
  for (size_t k = 0; k < c.impulses.size(); ++k) {
    const Vec3f lever = c.needle ? Vec3f{0.f, 0.f, 0.f}
                                 : 0.5f * (c.thread.points[k] + c.thread.points[k + 1]) - c.thread.points[0];
    sum.linear += c.impulses[k].linear;
    sum.angular += c.impulses[k].angular + cross(lever, c.impulses[k].linear);
  }
  return sum;
}
}  // namespace

ShapeImpulse Scene::curveImpulse(CurveId id) const {
  const auto held = impl_->reading("curveImpulse");
  return summedImpulse(impl_->idleRecord(impl_->curves, id, "curveImpulse"));
}
std::vector<ShapeImpulse> Scene::segmentImpulses(CurveId id) const {
  const auto held = impl_->reading("segmentImpulses");
  const CurveRecord& c = impl_->idleRecord(impl_->curves, id, "segmentImpulses");
  if (c.needle) return {summedImpulse(c)};
  return c.impulses;
}
std::vector<float> Scene::segmentContactMasses(CurveId id) const {
  const auto held = impl_->reading("segmentContactMasses");
  const CurveRecord& c = impl_->idleRecord(impl_->curves, id, "segmentContactMasses");
  if (c.contactMasses.size() != c.bodyCount()) return std::vector<float>(c.bodyCount(), 0.f);
  return c.contactMasses;
}
bool Scene::tipInside(CurveId id) const {
  const auto held = impl_->reading("tipInside");
  return impl_->curveOfKind(id, true, "tipInside").tipInside();
}
}  // namespace mpm
