// Tests of mpm_io: PLY files, the splat renderer and its PNG output, the progress bar.
#include <gtest/gtest.h>
#include <png.h>

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <iterator>
#include <sstream>
#include <string>
#include <vector>

#include "mpm/error.h"
#include "mpm/output.h"
#include "mpm_bullet/scene_file.h"
#include "ply_read.h"
#include "test_paths.h"

namespace mpm::io {
namespace {

std::string tempPath(const std::string& name) { return ::testing::TempDir() + "mpm_io_" + name; }

std::vector<unsigned char> readBytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::vector<unsigned char>(std::istreambuf_iterator<char>(in), {});
}

/// Splits a PLY file into its header lines and the binary payload after "end_header\n".
void splitPly(const std::vector<unsigned char>& bytes, std::vector<std::string>* headerLines,
              std::vector<unsigned char>* payload) {
  const std::string marker = "end_header\n";
  const std::string text(bytes.begin(), bytes.end());
  const size_t end = text.find(marker);
  ASSERT_NE(end, std::string::npos) << "no end_header";
  std::istringstream header(text.substr(0, end + marker.size()));
  for (std::string line; std::getline(header, line);) headerLines->push_back(line);
  payload->assign(bytes.begin() + static_cast<long>(end + marker.size()), bytes.end());
}

float littleEndianFloat(const unsigned char* p) {
  const uint32_t bits = uint32_t(p[0]) | uint32_t(p[1]) << 8 | uint32_t(p[2]) << 16 |
                        uint32_t(p[3]) << 24;
  float value;
  std::memcpy(&value, &bits, sizeof value);
  return value;
}

TEST(PlyWriter, HeaderAndPayloadOfPositions) {
  const std::vector<Vec3f> positions = {
      {0.1f, -2.5f, 1e-30f}, {123456.78f, 3.4e38f, -0.f}, {1.f / 3.f, 7.f, -1e-7f}};
  const std::string path = tempPath("positions.ply");
  writePly(path, positions);

  std::vector<std::string> header;
  std::vector<unsigned char> payload;
  splitPly(readBytes(path), &header, &payload);
  ASSERT_GE(header.size(), 7u);
  EXPECT_EQ(header[0], "ply");
  EXPECT_EQ(header[1], "format binary_little_endian 1.0");
  const std::vector<std::string> expectedTail = {"element vertex 3", "property float x",
                                                 "property float y", "property float z",
                                                 "end_header"};
  // comments may precede the element line; the declarations must close the header exactly
  EXPECT_EQ(std::vector<std::string>(header.end() - 5, header.end()), expectedTail);

  ASSERT_EQ(payload.size(), positions.size() * 3 * sizeof(float));
  for (size_t i = 0; i < positions.size(); ++i)
    for (int c = 0; c < 3; ++c)
      EXPECT_EQ(littleEndianFloat(&payload[(i * 3 + c) * 4]), positions[i][c])
          << "vertex " << i << " component " << c;
  std::remove(path.c_str());
}

TEST(PlyWriter, VelocitiesInterleavedAfterPositions) {
  const std::vector<Vec3f> positions = {{1.f, 2.f, 3.f}, {-4.f, 5.5f, 0.25f}};
  const std::vector<Vec3f> velocities = {{0.5f, -0.75f, 9.f}, {1e3f, -1e-3f, 2.f}};
  const std::string path = tempPath("velocities.ply");
  writePly(path, positions, &velocities);

  std::vector<std::string> header;
  std::vector<unsigned char> payload;
  splitPly(readBytes(path), &header, &payload);
  ASSERT_GE(header.size(), 10u);
  const std::vector<std::string> expectedTail = {
      "element vertex 2", "property float x",  "property float y",  "property float z",
      "property float vx", "property float vy", "property float vz", "end_header"};
  EXPECT_EQ(std::vector<std::string>(header.end() - 8, header.end()), expectedTail);

  ASSERT_EQ(payload.size(), positions.size() * 6 * sizeof(float));
  for (size_t i = 0; i < positions.size(); ++i) {
    for (int c = 0; c < 3; ++c) {
      EXPECT_EQ(littleEndianFloat(&payload[(i * 6 + c) * 4]), positions[i][c]);
      EXPECT_EQ(littleEndianFloat(&payload[(i * 6 + 3 + c) * 4]), velocities[i][c]);
    }
  }
  std::remove(path.c_str());
}

TEST(PlyWriter, VelocitiesOfOtherSizeAreLeftOut) {
  const std::vector<Vec3f> positions = {{1.f, 2.f, 3.f}, {4.f, 5.f, 6.f}};
  const std::vector<Vec3f> velocities = {{1.f, 1.f, 1.f}};
  const std::string path = tempPath("mismatch.ply");
  writePly(path, positions, &velocities);
  std::vector<std::string> header;
  std::vector<unsigned char> payload;
  splitPly(readBytes(path), &header, &payload);
  for (const std::string& line : header) EXPECT_EQ(line.find("vx"), std::string::npos);
  EXPECT_EQ(payload.size(), positions.size() * 3 * sizeof(float));
  std::remove(path.c_str());
}

TEST(PlyWriter, ColouredPointsAndPolylinesReadBack) {
  PlyFrame frame;
  frame.addPoints({{0.1f, -2.5f, 1e-30f}, {3.f, 4.f, 5.f}}, {215, 110, 105});
  frame.addPolyline({{0.f, 0.f, 0.f}, {1.f, 0.f, 0.f}, {1.f, 1.f, -7.25f}}, {40, 90, 200});
  const std::string path = tempPath("frame.ply");
  writePly(path, frame);
  const test::PlyRead r = test::readPly(path);
  EXPECT_EQ(r.header.front(), "ply");
  EXPECT_EQ(r.header[1], "format binary_little_endian 1.0");
  EXPECT_EQ(r.vertexCount, 5u);
  EXPECT_EQ(r.edgeCount, 2u);
  EXPECT_EQ(r.trailingBytes, 0u);
  ASSERT_EQ(r.frame.points.size(), 5u);
  for (size_t i = 0; i < 5; ++i)
    for (int c = 0; c < 3; ++c) EXPECT_EQ(r.frame.points[i][c], frame.points[i][c]) << "vertex " << i;
  EXPECT_EQ(r.frame.colours[1].r, 215);
  EXPECT_EQ(r.frame.colours[4].b, 200);
  // the polyline's points follow the two lone ones: edges 2-3 and 3-4
  ASSERT_EQ(r.frame.edges.size(), 2u);
  EXPECT_EQ(r.frame.edges[0], (std::array<int, 2>{2, 3}));
  EXPECT_EQ(r.frame.edges[1], (std::array<int, 2>{3, 4}));
  std::remove(path.c_str());
}

TEST(PlyWriter, AnEdgeBeyondThePointsIsRefused) {
  PlyFrame frame;
  frame.addPoints({{0.f, 0.f, 0.f}}, {});
  frame.edges.push_back({0, 1});
  EXPECT_THROW(writePly(tempPath("bad_edge.ply"), frame), Error);
  frame.edges.clear();
  frame.colours.clear();
  EXPECT_THROW(writePly(tempPath("no_colour.ply"), frame), Error);
}

TEST(PlyWriter, MissingDirectoryThrowsNamingPath) {
  const std::string path = "/nonexistent_mpm_io_dir/sub/points.ply";
  try {
    writePly(path, {{0.f, 0.f, 0.f}});
    FAIL() << "expected mpm::Error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
  }
}

// --- renderer --------------------------------------------------------------------------

/// Camera on the +z axis, 3 m from the origin, 160x120 pixels, 40 degree vertical field:
/// the focal length is 60 / tan(20 deg) = 164.8 px.
Camera frontCamera() {
  Camera camera;
  camera.eye = {0.f, 0.f, 3.f};
  camera.target = {0.f, 0.f, 0.f};
  camera.width = 160;
  camera.height = 120;
  return camera;
}

struct Pixel {
  int r, g, b;
};

Pixel pixelAt(const std::vector<uint8_t>& image, const Camera& camera, int x, int y) {
  const size_t i = (static_cast<size_t>(y) * camera.width + x) * 3;
  return {image[i], image[i + 1], image[i + 2]};
}

bool samePixel(Pixel a, Pixel b) { return a.r == b.r && a.g == b.g && a.b == b.b; }

/// Red dominates and green and blue stay alike: the hue of Rgb{200, 40, 40} under shading.
bool looksRed(Pixel p) { return p.r > 2 * p.g && p.r > 2 * p.b && std::abs(p.g - p.b) <= 12; }
bool looksBlue(Pixel p) { return p.b > 2 * p.r && p.b > 2 * p.g && std::abs(p.r - p.g) <= 12; }
bool looksGreen(Pixel p) { return p.g > 2 * p.r && p.g > 2 * p.b && std::abs(p.r - p.b) <= 12; }

/// An RGB PNG read back with libpng; `width` and `height` set from its header.
std::vector<uint8_t> readPng(const std::string& path, unsigned* width, unsigned* height) {
  png_image png;
  std::memset(&png, 0, sizeof png);
  png.version = PNG_IMAGE_VERSION;
  if (!png_image_begin_read_from_file(&png, path.c_str())) throw Error(png.message);
  *width = png.width;
  *height = png.height;
  png.format = PNG_FORMAT_RGB;
  std::vector<uint8_t> pixels(PNG_IMAGE_SIZE(png));
  if (!png_image_finish_read(&png, nullptr, pixels.data(), 0, nullptr)) throw Error(png.message);
  return pixels;
}

TEST(SplatRenderer, ParticleAtTargetFillsCentreWithItsColour) {
  const Camera camera = frontCamera();
  SplatRenderer empty(camera);
  const std::vector<uint8_t> background = empty.render();

  SplatRenderer renderer(camera);
  const Rgb red{200, 40, 40};
  renderer.addParticles({{0.f, 0.f, 0.f}}, 0.5f, red);
  const std::vector<uint8_t> image = renderer.render();
  ASSERT_EQ(image.size(), size_t(160 * 120 * 3));

  const Pixel centre = pixelAt(image, camera, 80, 60);
  EXPECT_TRUE(looksRed(centre)) << centre.r << " " << centre.g << " " << centre.b;
  // lit by ambient plus most of the diffuse term, never far from the particle's own colour
  EXPECT_GT(centre.r, 0.5 * red.r);
  EXPECT_LT(centre.r, 1.25 * red.r);

  // the disc has the projected radius 164.8 * 0.5 / 3 = 27.5 px
  EXPECT_TRUE(looksRed(pixelAt(image, camera, 80 + 24, 60)));
  EXPECT_TRUE(looksRed(pixelAt(image, camera, 80, 60 - 24)));
  EXPECT_TRUE(samePixel(pixelAt(image, camera, 80 + 32, 60), pixelAt(background, camera, 112, 60)));

  for (auto [x, y] : {std::pair{0, 0}, {159, 0}, {0, 119}, {159, 119}})
    EXPECT_TRUE(samePixel(pixelAt(image, camera, x, y), pixelAt(background, camera, x, y)))
        << "corner " << x << "," << y;
  EXPECT_FALSE(samePixel(centre, pixelAt(background, camera, 80, 60)));
}

TEST(SplatRenderer, ParticleBehindCameraDrawsNothing) {
  const Camera camera = frontCamera();
  SplatRenderer empty(camera);
  SplatRenderer renderer(camera);
  // on the view axis behind the eye, and one just off it: a projection that forgot the
  // sign of the depth would mirror both onto the screen
  renderer.addParticles({{0.f, 0.f, 5.f}, {0.3f, 0.2f, 4.f}}, 0.5f, Rgb{200, 40, 40});
  EXPECT_EQ(renderer.render(), empty.render());
}

TEST(SplatRenderer, NearerParticleWinsWhateverTheOrder) {
  const Camera camera = frontCamera();
  const std::vector<Vec3f> near = {{0.f, 0.f, 1.f}};  // 2 m from the eye, radius 0.2 m
  const std::vector<Vec3f> far = {{0.f, 0.f, 0.f}};   // 3 m from the eye, radius 0.5 m
  for (bool nearFirst : {true, false}) {
    SplatRenderer renderer(camera);
    if (nearFirst) renderer.addParticles(near, 0.2f, Rgb{200, 40, 40});
    renderer.addParticles(far, 0.5f, Rgb{40, 40, 200});
    if (!nearFirst) renderer.addParticles(near, 0.2f, Rgb{200, 40, 40});
    const std::vector<uint8_t> image = renderer.render();
    EXPECT_TRUE(looksRed(pixelAt(image, camera, 80, 60))) << "nearFirst " << nearFirst;
    // the near disc spans 16.5 px, the far one 27.5 px: the ring between shows the far one
    EXPECT_TRUE(looksBlue(pixelAt(image, camera, 80 + 22, 60))) << "nearFirst " << nearFirst;
  }
}

TEST(SplatRenderer, DepthIsTheFrontSurfaceNotTheCentre) {
  const Camera camera = frontCamera();
  SplatRenderer renderer(camera);
  // the big sphere's surface faces the camera at 2.0 m; the small one sits just behind that
  // surface (front at 2.05 m) although its centre (2.1 m) is nearer than the big centre (3 m)
  renderer.addParticles({{0.f, 0.f, 0.f}}, 1.0f, Rgb{40, 40, 200});
  renderer.addParticles({{0.f, 0.f, 0.9f}}, 0.05f, Rgb{200, 40, 40});
  const Pixel centre = pixelAt(renderer.render(), camera, 80, 60);
  EXPECT_TRUE(looksBlue(centre)) << centre.r << " " << centre.g << " " << centre.b;
}

TEST(SplatRenderer, GroundIsGreyCheckerBelowSky) {
  Camera camera;
  camera.eye = {0.f, 1.f, 2.f};
  camera.target = {0.f, 0.f, 0.f};
  camera.width = 160;
  camera.height = 120;
  SplatRenderer sky(camera);
  SplatRenderer renderer(camera);
  renderer.setGround(0.f, 1.f);
  const std::vector<uint8_t> image = renderer.render();
  const std::vector<uint8_t> skyImage = sky.render();

  const Pixel centre = pixelAt(image, camera, 80, 60);
  EXPECT_FALSE(samePixel(centre, pixelAt(skyImage, camera, 80, 60)));
  EXPECT_EQ(centre.r, centre.g);
  EXPECT_EQ(centre.g, centre.b);
  // the top rows look above the horizon
  EXPECT_TRUE(samePixel(pixelAt(image, camera, 80, 0), pixelAt(skyImage, camera, 80, 0)));

  // two shades of grey across the centre row: the checks
  int lighter = 0, darker = 0;
  for (int x = 40; x < 120; ++x) {
    const Pixel p = pixelAt(image, camera, x, 60);
    if (p.r > centre.r + 10) ++lighter;
    if (p.r < centre.r - 10) ++darker;
  }
  EXPECT_GT(lighter + darker, 10);
}

TEST(SplatRenderer, BallOnGroundHidesTheGroundBehindIt) {
  Camera camera;
  camera.eye = {0.f, 1.f, 2.f};
  camera.target = {0.f, 0.f, 0.f};
  camera.width = 160;
  camera.height = 120;
  SplatRenderer renderer(camera);
  renderer.setGround(0.f, 1.f);
  renderer.addParticles({{0.f, 0.2f, 0.f}}, 0.2f, Rgb{200, 40, 40});
  // the centre projects 13.7 px above the image centre, its disc is 15.3 px in radius
  const Pixel p = pixelAt(renderer.render(), camera, 80, 47);
  EXPECT_TRUE(looksRed(p)) << p.r << " " << p.g << " " << p.b;
}

TEST(SplatRenderer, InvalidCameraIsRejected) {
  Camera camera;
  camera.width = 0;
  EXPECT_THROW(SplatRenderer{camera}, InvalidArgument);
  camera = Camera{};
  camera.target = camera.eye;
  EXPECT_THROW(SplatRenderer{camera}, InvalidArgument);
  SplatRenderer renderer{Camera{}};
  EXPECT_THROW(renderer.addParticles({}, -1.f, Rgb{}), InvalidArgument);
}

TEST(SplatRenderer, WritePngReadsBackWithLibpng) {
  Camera camera = frontCamera();
  camera.width = 97;  // odd sizes catch row-stride mistakes
  camera.height = 61;
  SplatRenderer renderer(camera);
  renderer.setGround(-0.5f, 2.f);
  renderer.addParticles({{0.f, 0.f, 0.f}, {0.3f, 0.1f, -0.2f}}, 0.25f, Rgb{90, 200, 90});
  const std::string path = tempPath("render.png");
  renderer.writePng(path);

  unsigned width = 0, height = 0;
  const std::vector<uint8_t> pixels = readPng(path, &width, &height);
  EXPECT_EQ(width, 97u);
  EXPECT_EQ(height, 61u);
  EXPECT_EQ(pixels, renderer.render());
  std::remove(path.c_str());
}

// A scene file's coloured bodies in mpm_run's pictures (LoadedScene::writePng): a capsule,
// a cylinder, a moving mesh (its convex hull) and a static mesh (its triangles), side by
// side in front of the camera at t = 0. The pixel where each one's centre projects has
// the body's hue; between them the sky shows.
TEST(ScenePictures, CapsulesCylindersAndMeshesAreDrawn) {
  const std::string json = R"({
    "settings": {"domain": {"lower": [-0.5, -0.3, -0.3], "upper": [0.5, 0.3, 0.3]}, "dx": 0.05},
    "world": {"gravity": [0, 0, 0]},
    "bodies": [
      {"name": "capsule", "mass": 1, "coupled": false, "color": [200, 40, 40],
       "pose": {"position": [-0.36, 0, 0]}, "shape": {"type": "capsule", "radius": 0.03, "halfHeight": 0.04}},
      {"name": "cylinder", "mass": 0, "coupled": false, "color": [40, 40, 200],
       "pose": {"position": [-0.12, 0, 0]}, "shape": {"type": "cylinder", "radius": 0.04, "halfHeight": 0.04}},
      {"name": "hull", "mass": 1, "coupled": false, "color": [40, 200, 40],
       "pose": {"position": [0.12, 0, 0]}, "shape": {"type": "mesh", "file": "sphere.obj"}},
      {"name": "triangles", "mass": 0, "coupled": false, "color": [200, 40, 40],
       "pose": {"position": [0.36, 0, 0]}, "shape": {"type": "mesh", "file": "box.gltf"}}
    ],
    "output": {"camera": {"eye": [0, 0, 1.2], "target": [0, 0, 0], "fovYDegrees": 40, "width": 320, "height": 240}}
  })";
  auto loaded = bullet::LoadedScene::fromString(json, test::assetPath(""));
  const std::string path = tempPath("bodies.png");
  loaded->writePng(path);
  unsigned width = 0, height = 0;
  const std::vector<uint8_t> image = readPng(path, &width, &height);
  ASSERT_EQ(width, 320u);
  ASSERT_EQ(height, 240u);
  Camera camera;
  camera.width = 320;
  camera.height = 240;
  // pixel column of a point on the plane z = 0: 160 + f x / 1.2, f = 120 / tan(20 deg)
  const auto column = [](double x) { return (int)(160 + 120 / std::tan(20 * M_PI / 180) * x / 1.2); };
  const Pixel capsule = pixelAt(image, camera, column(-0.36), 120);
  const Pixel cylinder = pixelAt(image, camera, column(-0.12), 120);
  const Pixel hull = pixelAt(image, camera, column(0.12), 120);
  const Pixel triangles = pixelAt(image, camera, column(0.36), 120);
  EXPECT_TRUE(looksRed(capsule)) << capsule.r << " " << capsule.g << " " << capsule.b;
  EXPECT_TRUE(looksBlue(cylinder)) << cylinder.r << " " << cylinder.g << " " << cylinder.b;
  EXPECT_TRUE(looksGreen(hull)) << hull.r << " " << hull.g << " " << hull.b;
  EXPECT_TRUE(looksRed(triangles)) << triangles.r << " " << triangles.g << " " << triangles.b;
  // the capsule's cap: 0.065 m above its centre is inside it (its top at 0.07 m), 0.09 m is not
  const auto row = [](double y) { return (int)(120 - 120 / std::tan(20 * M_PI / 180) * y / 1.2); };
  EXPECT_TRUE(looksRed(pixelAt(image, camera, column(-0.36), row(0.065))));
  for (double x : {-0.24, 0.0, 0.24}) {  // between the bodies
    const Pixel sky = pixelAt(image, camera, column(x), 120);
    EXPECT_FALSE(looksRed(sky) || looksBlue(sky) || looksGreen(sky)) << "x " << x;
  }
  EXPECT_FALSE(looksRed(pixelAt(image, camera, column(-0.36), row(0.09))));
  std::remove(path.c_str());
}

TEST(SplatRenderer, WritePngToMissingDirectoryThrowsNamingPath) {
  SplatRenderer renderer(frontCamera());
  const std::string path = "/nonexistent_mpm_io_dir/frame_0001.png";
  try {
    renderer.writePng(path);
    FAIL() << "expected mpm::Error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
  }
}

// --- progress bar ----------------------------------------------------------------------

std::vector<std::string> lines(const std::string& text) {
  std::vector<std::string> result;
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);) result.push_back(line);
  return result;
}

TEST(ProgressBar, PlainLinesAtEveryTenthWhenNotATerminal) {
  // capturing stderr redirects it to a file, so the bar takes its log-file form
  ::testing::internal::CaptureStderr();
  {
    ProgressBar bar("steps", 200);
    for (long long done = 0; done <= 200; ++done) bar.update(done);
    bar.finish();
    bar.finish();
  }
  const std::vector<std::string> printed = lines(::testing::internal::GetCapturedStderr());
  ASSERT_EQ(printed.size(), 11u);  // 0%, 10%, ..., 100%, each once
  EXPECT_EQ(printed[0].rfind("steps: 0/200 (0%)", 0), 0u) << printed[0];
  EXPECT_EQ(printed[5].rfind("steps: 100/200 (50%)", 0), 0u) << printed[5];
  EXPECT_EQ(printed[10].rfind("steps: 200/200 (100%)", 0), 0u) << printed[10];
  for (const std::string& line : printed) {
    EXPECT_NE(line.find(" s"), std::string::npos) << line;  // elapsed time
    EXPECT_NE(line.find("ETA"), std::string::npos) << line;
    EXPECT_EQ(line.find('\r'), std::string::npos) << line;
  }
}

TEST(ProgressBar, FinishPrintsTheFinalLineOnceAfterSparseUpdates) {
  ::testing::internal::CaptureStderr();
  {
    ProgressBar bar("frames", 7);
    bar.update(3);
    bar.finish();
  }
  const std::vector<std::string> printed = lines(::testing::internal::GetCapturedStderr());
  ASSERT_EQ(printed.size(), 2u);
  EXPECT_EQ(printed[0].rfind("frames: 3/7 (42%)", 0), 0u) << printed[0];
  EXPECT_EQ(printed[1].rfind("frames: 7/7 (100%)", 0), 0u) << printed[1];
}

}  // namespace
}  // namespace mpm::io
