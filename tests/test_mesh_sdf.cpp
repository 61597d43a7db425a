// Signed distance grids from triangle meshes (mpm/sdf_grid.h): distances against analytic
// shapes, signs, gradients, the watertight report, and rejected input.
//
// Assets come from the repository's assets/ folder (made by assets/generate_assets.py); the files
// are read here with a few lines of parsing so this suite needs neither assimp nor Bullet.
#include <gtest/gtest.h>

#include "test_paths.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <limits>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "mpm/error.h"
#include "mpm/sdf_grid.h"

#if defined(_OPENMP)
#include <omp.h>
#endif

namespace mpm {
namespace {

constexpr float kSphereRadius = 0.05f;  // [m] sphere.obj, generate_assets.py
constexpr float kBowlRadius = 0.05f;    // [m] bowl_open.ply
const Vec3f kSlabHalf{0.1f, 0.02f, 0.1f};  // [m] tissue_slab.stl

using mpm::test::assetPath;

// "v x y z" and "f a b c" lines (1-based, optional /vt/vn) of an OBJ file.
TriangleMesh readObj(const std::string& path) {
  std::ifstream in(path);
  EXPECT_TRUE(in.good()) << "cannot open " << path;
  TriangleMesh mesh;
  std::string line;
  while (std::getline(in, line)) {
    std::istringstream s(line);
    std::string tag;
    s >> tag;
    if (tag == "v") {
      Vec3f v;
      s >> v.x >> v.y >> v.z;
      mesh.vertices.push_back(v);
    } else if (tag == "f") {
      std::string corner;
      for (int c = 0; c < 3 && (s >> corner); ++c)
        mesh.indices.push_back(static_cast<uint32_t>(std::stoul(corner.substr(0, corner.find('/'))) - 1));
    }
  }
  return mesh;
}

// The ASCII PLY layout generate_assets.py writes: x y z vertices, then "3 a b c" faces.
TriangleMesh readAsciiPly(const std::string& path) {
  std::ifstream in(path);
  EXPECT_TRUE(in.good()) << "cannot open " << path;
  size_t vertexCount = 0, faceCount = 0;
  std::string line;
  while (std::getline(in, line) && line != "end_header") {
    std::istringstream s(line);
    std::string word, element;
    s >> word >> element;
    if (word == "element" && element == "vertex") s >> vertexCount;
    if (word == "element" && element == "face") s >> faceCount;
  }
  TriangleMesh mesh;
  mesh.vertices.resize(vertexCount);
  for (Vec3f& v : mesh.vertices) in >> v.x >> v.y >> v.z;
  for (size_t f = 0; f < faceCount; ++f) {
    int n = 0;
    uint32_t a = 0, b = 0, c = 0;
    in >> n >> a >> b >> c;
    EXPECT_EQ(n, 3);
    mesh.indices.insert(mesh.indices.end(), {a, b, c});
  }
  EXPECT_TRUE(in.good()) << path;
  return mesh;
}

// The slab of tissue_slab.stl, inline: 8 corners, 12 outward triangles.
TriangleMesh slabMesh() {
  TriangleMesh mesh;
  for (int ix = 0; ix < 2; ++ix)
    for (int iy = 0; iy < 2; ++iy)
      for (int iz = 0; iz < 2; ++iz)
        mesh.vertices.push_back({ix ? kSlabHalf.x : -kSlabHalf.x, iy ? kSlabHalf.y : -kSlabHalf.y,
                                 iz ? kSlabHalf.z : -kSlabHalf.z});
  const uint32_t quads[6][4] = {{0, 1, 3, 2}, {4, 6, 7, 5}, {0, 4, 5, 1}, {2, 3, 7, 6}, {0, 2, 6, 4}, {1, 5, 7, 3}};
  for (const auto& q : quads) mesh.indices.insert(mesh.indices.end(), {q[0], q[1], q[2], q[0], q[2], q[3]});
  return mesh;
}

double sphereDistance(Vec3f p) { return std::sqrt(double(p.x) * p.x + double(p.y) * p.y + double(p.z) * p.z) - kSphereRadius; }

double boxDistance(Vec3f p, Vec3f half) {
  const double q[3] = {std::abs(p.x) - half.x, std::abs(p.y) - half.y, std::abs(p.z) - half.z};
  const double outside = std::sqrt(std::pow(std::max(q[0], 0.0), 2) + std::pow(std::max(q[1], 0.0), 2) +
                                   std::pow(std::max(q[2], 0.0), 2));
  return outside + std::min(std::max({q[0], q[1], q[2]}), 0.0);
}

Vec3f nodePosition(const SignedDistanceGrid& g, int i, int j, int k) {
  return g.lower + g.cellSize * Vec3f{float(i), float(j), float(k)};
}
float nodeValue(const SignedDistanceGrid& g, int i, int j, int k) {
  return g.values[(size_t(i) * g.dims[1] + j) * g.dims[2] + k];
}

// How far the icosphere's surface dips below the sphere: R minus the smallest distance
// from the centre to a face's plane (every face's plane foot lies inside the face).
double chordSag(const TriangleMesh& mesh, double radius) {
  double nearest = radius;
  for (size_t t = 0; t < mesh.triangleCount(); ++t) {
    const Vec3f a = mesh.vertices[mesh.indices[3 * t]], b = mesh.vertices[mesh.indices[3 * t + 1]],
                c = mesh.vertices[mesh.indices[3 * t + 2]];
    const Vec3f n = cross(b - a, c - a);
    nearest = std::min(nearest, std::abs(double(dot(n, a))) / norm(n));
  }
  return radius - nearest;
}

Vec3f randomPoint(std::mt19937& rng, Vec3f lo, Vec3f hi) {
  std::uniform_real_distribution<float> u(0.f, 1.f);
  return {lo.x + u(rng) * (hi.x - lo.x), lo.y + u(rng) * (hi.y - lo.y), lo.z + u(rng) * (hi.z - lo.z)};
}

// ---------------------------------------------------------------- the sphere
//
// Grid: cell h = 1.6 mm over the 0.1 m sphere with 3 cells of padding (70^3 samples).
// Error budget at a point p inside the grid with |p| >= 0.3 R:
//   |grid(p) - (|p| - R)| <= |trilinear(sdf_mesh)(p) - sdf_mesh(p)| + |sdf_mesh(p) - sdf_sphere(p)|
//   - the second term is at most the chordal sag of the icosphere (its surface lies between
//     the spheres of radius R - sag and R), sag = 0.226 mm = 0.14 h for these 1280 faces;
//   - trilinear error of a smooth distance |p| - R: (h^2 / 8) * trace(Hessian) = h^2 / (4 r)
//     at r >= 0.3 R - sqrt(3) h = 12.2 mm, 0.033 h; plus the kinks of the polyhedron's
//     distance (ridges inside, edges outside) where the gradient turns by the dihedral
//     angle theta <= 0.15 rad between neighbouring faces: at most theta h / 4 = 0.04 h.
// So the tolerance is sag + 0.1 h = 0.386 mm (0.1 h > 0.033 h + 0.04 h). Measured over 19790
// points: max 0.244 mm (0.15 h), mean 0.151 mm, i.e. the sag dominates.
constexpr float kSphereCell = 0.0016f;

struct SphereFixture : ::testing::Test {
  static void SetUpTestSuite() {
    mesh = new TriangleMesh(readObj(assetPath("sphere.obj")));
    const auto start = std::chrono::steady_clock::now();
    grid = new SignedDistanceGrid(buildSignedDistanceGrid(*mesh, kSphereCell, 3));
    buildSeconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    sag = chordSag(*mesh, kSphereRadius);
  }
  static void TearDownTestSuite() {
    delete grid;
    delete mesh;
  }
  static TriangleMesh* mesh;
  static SignedDistanceGrid* grid;
  static double buildSeconds, sag;
};
TriangleMesh* SphereFixture::mesh = nullptr;
SignedDistanceGrid* SphereFixture::grid = nullptr;
double SphereFixture::buildSeconds = 0, SphereFixture::sag = 0;

TEST_F(SphereFixture, GridCoversTheMeshWithPadding) {
  ASSERT_EQ(mesh->vertices.size(), 642u);
  ASSERT_EQ(mesh->triangleCount(), 1280u);
  EXPECT_FLOAT_EQ(grid->cellSize, kSphereCell);
  for (int a = 0; a < 3; ++a) {
    EXPECT_LE(grid->lower[a], -kSphereRadius - 3 * kSphereCell + 1e-6f);
    EXPECT_GE(grid->upper()[a], kSphereRadius + 3 * kSphereCell - 1e-6f);
    EXPECT_LE(grid->upper()[a] - grid->lower[a], 2 * kSphereRadius + 7 * kSphereCell);
  }
  EXPECT_EQ(grid->values.size(), size_t(grid->dims[0]) * grid->dims[1] * grid->dims[2]);
  EXPECT_TRUE(grid->signReliable);
  EXPECT_TRUE(grid->signWarning.empty()) << grid->signWarning;
  std::printf("sphere SDF: %d x %d x %d samples over %zu triangles built in %.3f s; chord sag %.3g m = %.3f cells\n",
              grid->dims[0], grid->dims[1], grid->dims[2], mesh->triangleCount(), buildSeconds, sag,
              sag / kSphereCell);
  RecordProperty("build_seconds", std::to_string(buildSeconds));
}

TEST_F(SphereFixture, MatchesAnalyticDistance) {
  const double tolerance = sag + 0.1 * kSphereCell;
  std::mt19937 rng(12345);
  double worst = 0, sum = 0;
  int tested = 0;
  for (int n = 0; n < 20000; ++n) {
    const Vec3f p = randomPoint(rng, grid->lower, grid->upper());
    if (norm(p) < 0.3f * kSphereRadius) continue;  // the cone tip of the distance at the centre
    const double error = std::abs(grid->sample(p) - sphereDistance(p));
    ASSERT_LE(error, tolerance) << "at (" << p.x << ", " << p.y << ", " << p.z << ")";
    worst = std::max(worst, error);
    sum += error;
    ++tested;
  }
  EXPECT_GT(tested, 15000);
  std::printf("sphere SDF error over %d points: max %.3g m (%.3f cells), mean %.3g m; tolerance %.3g m\n", tested,
              worst, worst / kSphereCell, sum / tested, tolerance);
}

TEST_F(SphereFixture, ExactAtNodesUpToTheChordSag) {
  // at a node there is no interpolation: only the polyhedron-vs-sphere difference remains
  double worst = 0;
  for (int i = 0; i < grid->dims[0]; ++i)
    for (int j = 0; j < grid->dims[1]; ++j)
      for (int k = 0; k < grid->dims[2]; ++k) {
        const Vec3f p = nodePosition(*grid, i, j, k);
        const double error = std::abs(nodeValue(*grid, i, j, k) - sphereDistance(p));
        worst = std::max(worst, error);
      }
  EXPECT_LE(worst, sag + 1e-6);
}

TEST_F(SphereFixture, SignInsideAndOutside) {
  std::mt19937 rng(777);
  int inside = 0, outside = 0;
  const double band = sag + 0.1 * kSphereCell;  // closer to the surface the sign may go either way
  for (int n = 0; n < 20000; ++n) {
    const Vec3f p = randomPoint(rng, grid->lower, grid->upper());
    const double r = norm(p);
    if (r < kSphereRadius - band) {
      ASSERT_LT(grid->sample(p), 0.f) << "inside point r = " << r;
      ++inside;
    } else if (r > kSphereRadius + band) {
      ASSERT_GT(grid->sample(p), 0.f) << "outside point r = " << r;
      ++outside;
    }
  }
  EXPECT_GT(inside, 1000);
  EXPECT_GT(outside, 1000);
  EXPECT_NEAR(grid->sample({0, 0, 0}), -kSphereRadius, sag + kSphereCell);
}

TEST_F(SphereFixture, GradientIsRadialUnit) {
  // the trilinear gradient turns with the face normals (up to ~5 degrees from radial on
  // the icosphere) and blends the two sides of each kink (ridges inside, edges outside),
  // which shortens or lengthens it by a few percent: ask for 10 degrees, |g| in [0.9, 1.1]
  const float cosLimit = std::cos(10.f * 3.14159265f / 180.f);
  std::mt19937 rng(99);
  float worstCos = 1.f, lowest = 2.f, highest = 0.f;
  int tested = 0;
  for (int n = 0; n < 20000; ++n) {
    const Vec3f p = randomPoint(rng, grid->lower, grid->upper());
    const float r = norm(p);
    if (r < 0.4f * kSphereRadius) continue;
    const Vec3f g = grid->gradient(p);
    const float length = norm(g);
    const float c = dot(g, (1.f / r) * p) / length;
    ASSERT_GT(c, cosLimit) << "at r = " << r;
    ASSERT_GT(length, 0.9f) << "at r = " << r;
    ASSERT_LT(length, 1.1f) << "at r = " << r;
    worstCos = std::min(worstCos, c);
    lowest = std::min(lowest, length);
    highest = std::max(highest, length);
    ++tested;
  }
  std::printf("sphere SDF gradient over %d points: worst angle to radial %.2f deg, |g| in [%.3f, %.3f]\n", tested,
              std::acos(std::min(worstCos, 1.f)) * 180.f / 3.14159265f, lowest, highest);
}

TEST_F(SphereFixture, BeyondTheGridNeverUnderestimates) {
  std::mt19937 rng(4);
  for (int n = 0; n < 2000; ++n) {
    // up to 0.5 m away: far outside the 0.11 m grid
    const Vec3f p = randomPoint(rng, {-0.5f, -0.5f, -0.5f}, {0.5f, 0.5f, 0.5f});
    const double exact = sphereDistance(p);
    const float value = grid->sample(p);
    ASSERT_GE(value, exact - sag - 0.1 * kSphereCell);
    // |q| + |p - q| - |p| <= 2 |q| for the clamped point q: at most the box's diagonal
    ASSERT_LE(value, exact + norm(grid->upper() - grid->lower) + sag + 0.1 * kSphereCell);
    // the field grows away from the grid
    const Vec3f g = grid->gradient(p);
    ASSERT_GT(dot(g, p), 0.f);
  }
  // continuous across the grid's face
  const float edge = grid->upper().x;
  EXPECT_NEAR(grid->sample({edge + 1e-5f, 0.f, 0.f}), grid->sample({edge - 1e-5f, 0.f, 0.f}), 1e-4f);
  EXPECT_NEAR(grid->sample({edge + 0.1f, 0.f, 0.f}), grid->sample({edge, 0.f, 0.f}) + 0.1f, 1e-5f);
  const Vec3f g = grid->gradient({edge + 0.1f, 0.f, 0.f});
  EXPECT_NEAR(g.x, 1.f, 1e-5f);
}

TEST_F(SphereFixture, InsideOutMeshGivesTheSameField) {
  // a consistently inverted mesh is still watertight; |winding number| keeps the sign right
  TriangleMesh flipped = *mesh;
  for (size_t t = 0; t < flipped.triangleCount(); ++t) std::swap(flipped.indices[3 * t + 1], flipped.indices[3 * t + 2]);
  const SignedDistanceGrid original = buildSignedDistanceGrid(*mesh, 0.003f, 2);
  const SignedDistanceGrid other = buildSignedDistanceGrid(flipped, 0.003f, 2);
  ASSERT_EQ(other.values.size(), original.values.size());
  EXPECT_TRUE(other.signReliable);
  for (size_t s = 0; s < other.values.size(); ++s) {
    ASSERT_NEAR(other.values[s], original.values[s], 1e-7f) << s;  // corners in another order
    ASSERT_EQ(other.values[s] < 0.f, original.values[s] < 0.f) << s;
  }
}

// ---------------------------------------------------------------- the slab (a box)

TEST(MeshSdf, SlabIsExactAtNodes) {
  const float h = 0.005f;
  const SignedDistanceGrid grid = buildSignedDistanceGrid(slabMesh(), h, 2);
  EXPECT_TRUE(grid.signReliable);
  // 0.2 / 0.005 = 40 cells, 0.04 / 0.005 = 8 cells, plus 2 * 2 padding, plus one
  EXPECT_EQ(grid.dims[0], 45);
  EXPECT_EQ(grid.dims[1], 13);
  EXPECT_EQ(grid.dims[2], 45);
  double worst = 0;
  int inside = 0;
  for (int i = 0; i < grid.dims[0]; ++i)
    for (int j = 0; j < grid.dims[1]; ++j)
      for (int k = 0; k < grid.dims[2]; ++k) {
        const Vec3f p = nodePosition(grid, i, j, k);
        const double exact = boxDistance(p, kSlabHalf);
        worst = std::max(worst, std::abs(nodeValue(grid, i, j, k) - exact));
        inside += nodeValue(grid, i, j, k) < 0;
      }
  // a flat mesh has no sag: only float rounding of the node positions and values remains
  EXPECT_LE(worst, 1e-6);
  EXPECT_GT(inside, 1000);
}

TEST(MeshSdf, SlabBetweenNodesIsTrilinearAndBounded) {
  const float h = 0.005f;
  const SignedDistanceGrid grid = buildSignedDistanceGrid(slabMesh(), h, 2);
  std::mt19937 rng(2024);
  for (int n = 0; n < 20000; ++n) {
    const Vec3f p = randomPoint(rng, grid.lower, grid.upper());
    // reference: trilinear blend of the analytic distance at the cell's corners
    const Vec3f f = (1.f / h) * (p - grid.lower);
    const int i = std::min(int(f.x), grid.dims[0] - 2), j = std::min(int(f.y), grid.dims[1] - 2),
              k = std::min(int(f.z), grid.dims[2] - 2);
    const double t[3] = {f.x - i, f.y - j, f.z - k};
    double reference = 0;
    for (int c = 0; c < 8; ++c) {
      const int di = c >> 2, dj = (c >> 1) & 1, dk = c & 1;
      reference += (di ? t[0] : 1 - t[0]) * (dj ? t[1] : 1 - t[1]) * (dk ? t[2] : 1 - t[2]) *
                   boxDistance(nodePosition(grid, i + di, j + dj, k + dk), kSlabHalf);
    }
    const double value = grid.sample(p);
    ASSERT_NEAR(value, reference, 2e-6) << "at (" << p.x << ", " << p.y << ", " << p.z << ")";
    // a convex set's distance is convex, so trilinear interpolation never falls below it
    // (Jensen); being 1-Lipschitz it exceeds it by at most the mean distance to the
    // corners, <= sqrt(3)/2 h
    const double exact = boxDistance(p, kSlabHalf);
    ASSERT_GE(value, exact - 2e-6);
    ASSERT_LE(value, exact + 0.87 * h);
  }
  // gradient on the faces' normals, away from edges and the medial planes
  const Vec3f gy = grid.gradient({0.01f, 0.0301f, -0.02f});
  EXPECT_NEAR(gy.x, 0.f, 1e-4f);
  EXPECT_NEAR(gy.y, 1.f, 1e-4f);
  EXPECT_NEAR(gy.z, 0.f, 1e-4f);
  const Vec3f gx = grid.gradient({-0.0951f, 0.002f, 0.013f});
  EXPECT_NEAR(gx.x, -1.f, 1e-4f);
  EXPECT_NEAR(gx.y, 0.f, 1e-4f);
}

// ---------------------------------------------------------------- watertight report

TEST(MeshSdf, WatertightReport) {
  const WatertightReport sphere = checkWatertight(readObj(assetPath("sphere.obj")));
  EXPECT_TRUE(sphere.watertight) << sphere.reason;
  EXPECT_EQ(sphere.boundaryEdges + sphere.nonManifoldEdges + sphere.misorientedEdges, 0u);
  EXPECT_TRUE(sphere.reason.empty());

  const WatertightReport slab = checkWatertight(slabMesh());
  EXPECT_TRUE(slab.watertight) << slab.reason;

  const WatertightReport bowl = checkWatertight(readAsciiPly(assetPath("bowl_open.ply")));
  EXPECT_FALSE(bowl.watertight);
  EXPECT_EQ(bowl.boundaryEdges, 24u);  // the rim: 24 segments (generate_assets.py)
  EXPECT_EQ(bowl.nonManifoldEdges, 0u);
  EXPECT_EQ(bowl.misorientedEdges, 0u);
  EXPECT_NE(bowl.reason.find("24 boundary edges"), std::string::npos) << bowl.reason;

  TriangleMesh oneFlipped = slabMesh();
  std::swap(oneFlipped.indices[1], oneFlipped.indices[2]);
  const WatertightReport flipped = checkWatertight(oneFlipped);
  EXPECT_FALSE(flipped.watertight);
  EXPECT_EQ(flipped.misorientedEdges, 3u);
  EXPECT_EQ(flipped.boundaryEdges, 0u);

  TriangleMesh doubled = slabMesh();
  doubled.indices.insert(doubled.indices.end(), {0, 1, 3});  // a copy of the first triangle
  const WatertightReport nonManifold = checkWatertight(doubled);
  EXPECT_FALSE(nonManifold.watertight);
  EXPECT_EQ(nonManifold.nonManifoldEdges, 3u);

  EXPECT_FALSE(checkWatertight(TriangleMesh{}).watertight);
}

TEST(MeshSdf, OpenMeshSignIsFlaggedUnreliable) {
  const TriangleMesh bowl = readAsciiPly(assetPath("bowl_open.ply"));
  ASSERT_EQ(bowl.triangleCount(), 360u);
  const SignedDistanceGrid grid = buildSignedDistanceGrid(bowl, 0.004f, 2);
  EXPECT_FALSE(grid.signReliable);
  EXPECT_NE(grid.signWarning.find("not watertight"), std::string::npos) << grid.signWarning;
  EXPECT_NE(grid.signWarning.find("24 boundary edges"), std::string::npos) << grid.signWarning;
  // the winding number still classifies the bowl's deep inside and the outside below it
  EXPECT_LT(grid.sample({0.f, -0.035f, 0.f}), 0.f);
  EXPECT_GT(grid.sample({0.f, -0.06f, 0.f}), 0.f);
  EXPECT_GT(grid.sample({0.07f, -0.02f, 0.f}), 0.f);
  // the magnitude is the distance to the shell whatever the sign: R - |p| inside it, |p| - R
  // outside, give or take the shell's chord sag (faces 11.25 x 15 degrees: < 0.7 mm) and
  // interpolation (points away from the axis, where the distance has a cone-like kink)
  for (const Vec3f p : {Vec3f{0.03f, -0.02f, 0.f}, Vec3f{-0.01f, -0.025f, 0.02f}, Vec3f{0.045f, -0.04f, 0.f},
                        Vec3f{0.f, -0.058f, 0.012f}})
    EXPECT_NEAR(std::abs(grid.sample(p)), std::abs(norm(p) - kBowlRadius), 1e-3f)
        << "at (" << p.x << ", " << p.y << ", " << p.z << ")";
}

// ---------------------------------------------------------------- rejected input

template <class F>
void expectRejected(F bad, const std::string& field) {
  try {
    bad();
    ADD_FAILURE() << "no error for " << field;
  } catch (const InvalidArgument& e) {
    EXPECT_EQ(e.field(), field) << e.what();
  }
}

TEST(MeshSdf, RejectsBadInput) {
  const TriangleMesh good = slabMesh();
  expectRejected([] { buildSignedDistanceGrid(TriangleMesh{}, 0.01f); }, "TriangleMesh.vertices");
  TriangleMesh noTriangles = good;
  noTriangles.indices.clear();
  expectRejected([&] { buildSignedDistanceGrid(noTriangles, 0.01f); }, "TriangleMesh.indices");
  TriangleMesh ragged = good;
  ragged.indices.pop_back();
  expectRejected([&] { buildSignedDistanceGrid(ragged, 0.01f); }, "TriangleMesh.indices");
  TriangleMesh outOfRange = good;
  outOfRange.indices[5] = 8;
  expectRejected([&] { buildSignedDistanceGrid(outOfRange, 0.01f); }, "TriangleMesh.indices[5]");
  TriangleMesh notFinite = good;
  notFinite.vertices[3].y = std::numeric_limits<float>::quiet_NaN();
  expectRejected([&] { buildSignedDistanceGrid(notFinite, 0.01f); }, "TriangleMesh.vertices[3]");
  for (float cell : {0.f, -0.01f, std::numeric_limits<float>::quiet_NaN(), std::numeric_limits<float>::infinity()})
    expectRejected([&] { buildSignedDistanceGrid(good, cell); }, "cellSize");
  // a cell size that would need billions of samples: a unit mistake, not a request
  expectRejected([&] { buildSignedDistanceGrid(good, 1e-5f); }, "cellSize");
  expectRejected([&] { buildSignedDistanceGrid(good, 0.01f, 0); }, "paddingCells");
  expectRejected([&] { buildSignedDistanceGrid(good, 0.01f, -2); }, "paddingCells");
  expectRejected([&] { buildSignedDistanceGrid(good, 0.01f, 1 << 30); }, "paddingCells");
  // the message names the value too
  try {
    buildSignedDistanceGrid(good, -0.25f);
  } catch (const InvalidArgument& e) {
    EXPECT_NE(std::string(e.what()).find("-0.25"), std::string::npos) << e.what();
  }
}

#if defined(_OPENMP)
TEST(MeshSdf, SameValuesOnAnyThreadCount) {
  const TriangleMesh sphere = readObj(assetPath("sphere.obj"));
  const TriangleMesh bowl = readAsciiPly(assetPath("bowl_open.ply"));
  const int threads = omp_get_max_threads();
  omp_set_num_threads(1);
  const SignedDistanceGrid sphereOne = buildSignedDistanceGrid(sphere, 0.004f, 2);
  const SignedDistanceGrid bowlOne = buildSignedDistanceGrid(bowl, 0.004f, 2);
  omp_set_num_threads(4);
  const SignedDistanceGrid sphereFour = buildSignedDistanceGrid(sphere, 0.004f, 2);
  const SignedDistanceGrid bowlFour = buildSignedDistanceGrid(bowl, 0.004f, 2);
  omp_set_num_threads(threads);
  EXPECT_EQ(sphereOne.values, sphereFour.values);
  EXPECT_EQ(bowlOne.values, bowlFour.values);
}
#endif

TEST(MeshSdf, EmptyGridAnswersFar) {
  const SignedDistanceGrid empty;
  EXPECT_TRUE(std::isinf(empty.sample({0.f, 0.f, 0.f})));
  const Vec3f g = empty.gradient({0.f, 0.f, 0.f});
  EXPECT_EQ(g.x + g.y + g.z, 0.f);
}

}  // namespace
}  // namespace mpm
