// Rigid shapes: primitive signed distances against closed forms, and the grid contact
// of DESIGN section 5 against momentum balance.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "mpm/scene.h"
#include "shapes/sdf_primitives.h"

namespace mpm {
namespace {

// Normals must be the gradient of the distance: compare with central differences.
template <class F>
void expectNormalIsGradient(F sdf, Vec3f p, float tol) {
  Vec3f n, dummy;
  sdf(p, n);
  const float h = 1e-3f;
  for (int a = 0; a < 3; ++a) {
    Vec3f q1 = p, q0 = p;
    q1[a] += h;
    q0[a] -= h;
    const float g = (sdf(q1, dummy) - sdf(q0, dummy)) / (2 * h);
    EXPECT_NEAR(n[a], g, tol) << "axis " << a << " at (" << p.x << ", " << p.y << ", " << p.z << ")";
  }
}

TEST(ShapeSdf, PrimitivesMatchClosedForms) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<float> u(-0.3f, 0.3f);
  const Vec3f h{0.1f, 0.05f, 0.08f};
  for (int t = 0; t < 2000; ++t) {
    const Vec3f p{u(rng), u(rng), u(rng)};
    Vec3f n;
    // sphere
    EXPECT_NEAR(sdfSphere(p, 0.1f, n), norm(p) - 0.1f, 1e-6f);
    // box: exterior distance to the clamped point, interior minus distance to nearest face
    const Vec3f c{std::fmax(-h.x, std::fmin(h.x, p.x)), std::fmax(-h.y, std::fmin(h.y, p.y)),
                  std::fmax(-h.z, std::fmin(h.z, p.z))};
    const bool inside = std::fabs(p.x) < h.x && std::fabs(p.y) < h.y && std::fabs(p.z) < h.z;
    const float face = std::fmin(std::fmin(h.x - std::fabs(p.x), h.y - std::fabs(p.y)), h.z - std::fabs(p.z));
    EXPECT_NEAR(sdfBox(p, h, n), inside ? -face : norm(p - c), 1e-6f);
    // capsule on z: distance to the segment minus radius
    const Vec3f s{0.f, 0.f, std::fmax(-0.1f, std::fmin(0.1f, p.z))};
    EXPECT_NEAR(sdfCapsule(p, 0.04f, 0.1f, 2, n), norm(p - s) - 0.04f, 1e-6f);
    // cylinder on x: exterior rim distance or nearest of side / cap
    const float rho = std::sqrt(p.y * p.y + p.z * p.z), dr = rho - 0.06f, da = std::fabs(p.x) - 0.12f;
    const float cyl = (dr > 0 && da > 0) ? std::sqrt(dr * dr + da * da) : std::fmax(dr, da);
    EXPECT_NEAR(sdfCylinder(p, 0.06f, 0.12f, 0, n), cyl, 1e-6f);
    EXPECT_NEAR(sdfPlane(p, n), p.y, 0.f);
    if (t % 20 == 0) {
      expectNormalIsGradient([&](Vec3f q, Vec3f& m) { return sdfBox(q, h, m); }, p, 2e-2f);
      expectNormalIsGradient([&](Vec3f q, Vec3f& m) { return sdfCapsule(q, 0.04f, 0.1f, 2, m); }, p, 2e-2f);
      expectNormalIsGradient([&](Vec3f q, Vec3f& m) { return sdfCylinder(q, 0.06f, 0.12f, 0, m); }, p, 2e-2f);
    }
  }
}

SceneSettings contactScene() {
  SceneSettings s;
  s.domain.lower = {-0.3f, 0.f, -0.3f};
  s.domain.upper = {0.3f, 0.6f, 0.3f};
  s.domain.wallMode = WallMode::Slip;
  s.dx = 0.02f;
  s.gravity = {0.f, -9.81f, 0.f};
  return s;
}

ParticleObjectDesc softBlock() {
  ParticleObjectDesc d;
  d.center = {0.f, 0.04f + 0.05f, 0.f};  // resting on the floor wall (2 cells)
  d.halfExtents = {0.15f, 0.05f, 0.15f};
  d.material.model = MaterialModel::NeoHookeanDecoupled;
  d.material.youngsModulus = 2e5f;
  d.material.poissonRatio = 0.3f;
  d.material.density = 1000.f;
  return d;
}

// A dynamic box resting on a soft block: averaged over time, the grid holds it up with
// m g (momentum balance), and it does not sink into the tissue.
TEST(ShapeContact, RestingBoxIsHeldByItsWeight) {
  Scene scene(contactScene());
  const ParticleObjectId tissue = scene.addParticleObject(softBlock());
  ShapeDesc box;
  Geometry g;
  g.type = GeometryType::Box;
  g.halfExtents = {0.05f, 0.03f, 0.05f};
  box.parts = {g};
  const float top = 0.04f + 0.1f;
  box.pose.position = {0.f, top + 0.03f + 0.01f, 0.f};
  box.mass = 2.f;
  box.inertia = {2.f / 3.f * (0.03f * 0.03f + 0.05f * 0.05f), 2.f / 3.f * 2 * 0.05f * 0.05f,
                 2.f / 3.f * (0.03f * 0.03f + 0.05f * 0.05f)};
  box.gravity = {0.f, -9.81f, 0.f};
  box.contact.mode = ContactMode::Frictional;
  box.contact.friction = 0.5f;
  const ShapeId id = scene.addShape(box);
  const float frame = 0.005f;
  for (int f = 0; f < 100; ++f) scene.step(frame);  // settle 0.5 s
  double impulse = 0;
  const int frames = 100;
  for (int f = 0; f < frames; ++f) {
    scene.step(frame);
    impulse += scene.shapeImpulse(id).linear.y;
  }
  const double force = impulse / (frames * frame);
  EXPECT_NEAR(force, 2.0 * 9.81, 0.02 * 2.0 * 9.81) << "time-averaged support force [N]";
  // penetration: the box bottom against the tissue top (highest particle under the box)
  std::vector<Vec3f> x;
  scene.readPositions(tissue, x);
  float surface = 0.f;
  for (const Vec3f& p : x)
    if (std::fabs(p.x) < 0.04f && std::fabs(p.z) < 0.04f) surface = std::fmax(surface, p.y);
  const float bottom = scene.shapeState(id).pose.position.y - 0.03f;
  EXPECT_GT(bottom - surface, -0.5f * 0.02f) << "box bottom " << bottom << " tissue top " << surface;
  EXPECT_LT(bottom - surface, 0.5f * 0.02f) << "box bottom " << bottom << " tissue top " << surface;
}

// Zero gravity, no walls: a dynamic sphere thrown at a free soft block. Total momentum of
// sphere plus particles is conserved through the collision.
TEST(ShapeContact, ThrownSphereConservesTotalMomentum) {
  SceneSettings s = contactScene();
  s.gravity = {0.f, 0.f, 0.f};
  s.domain.walls = false;
  Scene scene(s);
  ParticleObjectDesc b = softBlock();
  b.center = {0.05f, 0.3f, 0.f};
  b.halfExtents = {0.06f, 0.06f, 0.06f};
  const ParticleObjectId tissue = scene.addParticleObject(b);
  ShapeDesc ball;
  Geometry g;
  g.type = GeometryType::Sphere;
  g.radius = 0.04f;
  ball.parts = {g};
  ball.pose.position = {-0.1f, 0.3f, 0.f};
  ball.linearVelocity = {2.f, 0.f, 0.f};
  ball.mass = 0.5f;
  const float I = 0.4f * 0.5f * 0.04f * 0.04f;
  ball.inertia = {I, I, I};
  const ShapeId id = scene.addShape(ball);
  const double p0 = 0.5 * 2.0;
  for (int f = 0; f < 30; ++f) scene.step(0.005f);
  const ObjectSummary t = scene.summary(tissue);
  const ShapeState st = scene.shapeState(id);
  EXPECT_GT(t.momentum[0], 0.2 * p0) << "the sphere hit the block and pushed it";
  const double px = t.momentum[0] + 0.5 * st.linearVelocity.x;
  const double py = t.momentum[1] + 0.5 * st.linearVelocity.y;
  EXPECT_NEAR(px, p0, 0.01 * p0);
  EXPECT_NEAR(py, 0.0, 0.01 * p0);
}

// ---------------------------------------------------------------------------------------
// A backend keeps a device copy of each mesh shape's distance values. The copy must follow
// the grid it came from, not the address the grid had: a mesh shape removed and another
// added whose grid lands where the freed one was must be seen with the new values (issue
// 13: keyed by address, the new shape got the old values, impulse 0 instead of the plane's).

/// Hands out one fixed block while it is free (else the heap): a grid made right after
/// another was freed lands at the freed one's address, as a general allocator may do.
struct ReusedBlock {
  alignas(64) static inline unsigned char bytes[4096];
  static inline bool busy = false;
};
template <class T>
struct ReusingAllocator {
  using value_type = T;
  ReusingAllocator() = default;
  template <class U>
  ReusingAllocator(const ReusingAllocator<U>&) {}
  T* allocate(size_t n) {
    if (!ReusedBlock::busy && n * sizeof(T) <= sizeof(ReusedBlock::bytes)) {
      ReusedBlock::busy = true;
      return reinterpret_cast<T*>(ReusedBlock::bytes);
    }
    return static_cast<T*>(::operator new(n * sizeof(T)));
  }
  void deallocate(T* p, size_t) {
    if ((void*)p == (void*)ReusedBlock::bytes)
      ReusedBlock::busy = false;
    else
      ::operator delete(p);
  }
  template <class U>
  bool operator==(const ReusingAllocator<U>&) const { return true; }
  template <class U>
  bool operator!=(const ReusingAllocator<U>&) const { return false; }
};

/// The half-space y <= y0 as a sampled field y - y0 over the whole domain of
/// contactScene(): trilinear interpolation of a linear field is exact, so this mesh shape
/// is the plane itself.
std::shared_ptr<SignedDistanceGrid> planeGrid(float y0, float cell) {
  auto g = std::allocate_shared<SignedDistanceGrid>(ReusingAllocator<SignedDistanceGrid>());
  g->lower = {-0.4f, -0.1f, -0.4f};
  g->cellSize = cell;
  for (int a = 0; a < 3; ++a) g->dims[a] = (int)std::lround(0.8f / cell) + 1;
  g->values.resize((size_t)g->dims[0] * g->dims[1] * g->dims[2]);
  for (int i = 0; i < g->dims[0]; ++i)
    for (int j = 0; j < g->dims[1]; ++j)
      for (int k = 0; k < g->dims[2]; ++k)
        g->values[((size_t)i * g->dims[1] + j) * g->dims[2] + k] = g->lower.y + j * cell - y0;
  return g;
}

// The CPU backend always; CUDA (a device copy proper) where a device exists.
class MeshCache : public ::testing::TestWithParam<Backend> {};

TEST_P(MeshCache, MeshGridAtAFreedGridsAddressIsSeenAfresh) {
  if (GetParam() == Backend::Cuda && !cudaDeviceAvailable()) GTEST_SKIP() << "no CUDA device: GPU case skipped";
  SceneSettings s = contactScene();
  s.backend = GetParam();
  s.gravity = {0.f, 0.f, 0.f};
  ParticleObjectDesc b = softBlock();
  b.center = {0.f, 0.3f, 0.f};  // bottom at 0.25 m, falling at 1 m/s
  b.velocity = {0.f, -1.f, 0.f};
  const float frame = 0.01f, y0 = 0.25f;  // after one frame the bottom is 1 cm below y0
  // reference: one free frame, then the analytic plane y <= y0 for one frame
  Scene ref(s);
  ref.addParticleObject(b);
  ref.step(frame);
  ShapeDesc plane;
  plane.parts = {Geometry{}};
  plane.parts[0].type = GeometryType::Plane;
  plane.pose.position = {0.f, y0, 0.f};
  const ShapeId planeId = ref.addShape(plane);
  ref.step(frame);
  const float expected = ref.shapeImpulse(planeId).linear.y;
  ASSERT_LT(expected, -0.5f) << "the plane stops the tissue's bottom";
  // the old grid: the same size, then larger (finer), and a plane far below the tissue
  for (const float oldCell : {0.02f, 0.01f}) {
    Scene scene(s);
    scene.addParticleObject(b);
    ShapeDesc far;
    far.parts = {Geometry{}};
    far.parts[0].type = GeometryType::Mesh;
    far.parts[0].sdf = planeGrid(-1.f, oldCell);
    const void* oldAddress = far.parts[0].sdf.get();
    const ShapeId farId = scene.addShape(far);
    scene.step(frame);  // the backend copies the far grid's values
    EXPECT_EQ(scene.shapeImpulse(farId).linear.y, 0.f) << "the far plane touches nothing";
    scene.removeShape(farId);
    far = ShapeDesc{};  // the scene and the test hold the old grid no more
    ShapeDesc near;
    near.parts = {Geometry{}};
    near.parts[0].type = GeometryType::Mesh;
    near.parts[0].sdf = planeGrid(y0, 0.02f);
    const bool reused = near.parts[0].sdf.get() == oldAddress;
    const ShapeId nearId = scene.addShape(near);
    scene.step(frame);
    const float got = scene.shapeImpulse(nearId).linear.y;
    std::printf("old grid cell %.3f m: new grid %s the old one's address; impulse %.5f N s, analytic plane %.5f N s\n",
                oldCell, reused ? "at" : "not at", got, expected);
    EXPECT_NEAR(got, expected, 1e-3f * std::fabs(expected)) << "old grid cell " << oldCell;
  }
}

INSTANTIATE_TEST_SUITE_P(Backends, MeshCache, ::testing::Values(Backend::Cpu, Backend::Cuda),
                         [](const ::testing::TestParamInfo<Backend>& i) {
                           return std::string(i.param == Backend::Cpu ? "Cpu" : "Cuda");
                         });

}  // namespace
}  // namespace mpm
