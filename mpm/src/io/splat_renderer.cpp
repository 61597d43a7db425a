// Headless splat renderer: each particle is a screen-space disc shaded as the sphere it
// stands for, z-buffered against the other particles and an optional checkerboard ground.
#include <png.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <string>
#include <vector>

#include "mpm/error.h"
#include "mpm/output.h"

namespace mpm::io {
namespace {

constexpr float kPi = 3.14159265358979f;
constexpr float kNearPlane = 1e-3f;     // [m] particles whose centre is nearer are skipped
constexpr float kCheckerSize = 0.1f;    // [m] side of one ground square
constexpr float kAmbient = 0.30f;
constexpr float kDiffuse = 0.70f;
constexpr float kSpecular = 0.25f;

Vec3f normalized(Vec3f v) {
  const float length = norm(v);
  return length > 0.f ? (1.f / length) * v : v;
}

float clamp01(float v) { return v < 0.f ? 0.f : (v > 1.f ? 1.f : v); }

uint8_t toByte(float unit) { return static_cast<uint8_t>(clamp01(unit) * 255.f + 0.5f); }

float pow32(float s) {
  s *= s; s *= s; s *= s; s *= s; s *= s;
  return s;
}

/// Camera frame and projection derived once per render.
struct View {
  Vec3f eye, forward, right, up;  // orthonormal, right-handed: right x up = -forward
  float focalPixels;              // [px] distance of the image plane for unit depth
  float centreX, centreY;         // [px]
  int width, height;
  /// Light direction (towards the light) in camera coordinates (right, up, forward).
  Vec3f lightCam;
  /// Blinn half vector for a viewer looking along +forward, in camera coordinates.
  Vec3f halfCam;

  /// Ray through the centre of pixel (px, py), scaled so its forward component is 1:
  /// the ray parameter at a hit is then the camera depth that the z-buffer stores.
  Vec3f pixelRay(int px, int py) const {
    const float a = (static_cast<float>(px) + 0.5f - centreX) / focalPixels;
    const float b = (static_cast<float>(py) + 0.5f - centreY) / focalPixels;
    return forward + a * right - b * up;
  }
  Vec3f toWorld(Vec3f cam) const { return cam.x * right + cam.y * up + cam.z * forward; }
};

View makeView(const Camera& camera) {
  View v;
  v.eye = camera.eye;
  v.forward = normalized(camera.target - camera.eye);
  v.right = normalized(cross(v.forward, camera.up));
  v.up = cross(v.right, v.forward);
  v.width = camera.width;
  v.height = camera.height;
  v.centreX = 0.5f * static_cast<float>(camera.width);
  v.centreY = 0.5f * static_cast<float>(camera.height);
  v.focalPixels = 0.5f * static_cast<float>(camera.height) / std::tan(0.5f * camera.fovYDegrees * kPi / 180.f);
  // a key light above-left and behind the viewer, fixed to the camera so that whatever
  // side is shown is lit; the specular uses the distant-viewer approximation
  v.lightCam = normalized(Vec3f{-0.45f, 0.75f, -0.5f});
  v.halfCam = normalized(v.lightCam + Vec3f{0.f, 0.f, -1.f});
  return v;
}

/// Sky colour for a ray direction: pale at the horizon, blue towards the zenith.
void skyColour(Vec3f ray, float out[3]) {
  const float elevation = ray.y / norm(ray);
  const float horizon[3] = {0.87f, 0.90f, 0.94f};
  const float zenith[3] = {0.42f, 0.60f, 0.84f};
  const float below[3] = {0.74f, 0.76f, 0.79f};
  const float t = clamp01(elevation * 1.6f);
  for (int c = 0; c < 3; ++c)
    out[c] = elevation >= 0.f ? horizon[c] + t * (zenith[c] - horizon[c])
                              : below[c] + clamp01(1.f + 4.f * elevation) * (horizon[c] - below[c]);
}

/// libpng reports errors through this record instead of aborting the process.
struct PngErrorRecord {
  char message[256];
};

void onPngError(png_structp png, png_const_charp message) {
  auto* record = static_cast<PngErrorRecord*>(png_get_error_ptr(png));
  std::snprintf(record->message, sizeof record->message, "%s", message);
  // returning makes libpng longjmp to the setjmp in encodePng
}

void onPngWarning(png_structp, png_const_charp) {}

/// Encodes an RGB buffer to `file`. Only trivially destructible locals live past setjmp,
/// so the longjmp of a libpng error skips no destructor. Returns false with `error` set.
bool encodePng(std::FILE* file, const uint8_t* rgb, int width, int height,
               PngErrorRecord* error) {
  png_structp png =
      png_create_write_struct(PNG_LIBPNG_VER_STRING, error, onPngError, onPngWarning);
  if (png == nullptr) {
    std::snprintf(error->message, sizeof error->message, "out of memory");
    return false;
  }
  png_infop info = png_create_info_struct(png);
  if (info == nullptr) {
    png_destroy_write_struct(&png, nullptr);
    std::snprintf(error->message, sizeof error->message, "out of memory");
    return false;
  }
  if (setjmp(png_jmpbuf(png))) {
    png_destroy_write_struct(&png, &info);
    return false;
  }
  png_init_io(png, file);
  png_set_IHDR(png, info, static_cast<png_uint_32>(width), static_cast<png_uint_32>(height), 8,
               PNG_COLOR_TYPE_RGB, PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT,
               PNG_FILTER_TYPE_DEFAULT);
  png_write_info(png, info);
  for (int row = 0; row < height; ++row)
    png_write_row(png, rgb + static_cast<size_t>(row) * width * 3);
  png_write_end(png, nullptr);
  png_destroy_write_struct(&png, &info);
  return true;
}

}  // namespace

SplatRenderer::SplatRenderer(const Camera& camera) : camera_(camera) {
  if (camera.width <= 0 || camera.width > 1 << 15)
    throw InvalidArgument("Camera.width", std::to_string(camera.width), "must be in 1..32768");
  if (camera.height <= 0 || camera.height > 1 << 15)
    throw InvalidArgument("Camera.height", std::to_string(camera.height), "must be in 1..32768");
  if (!(camera.fovYDegrees > 0.f && camera.fovYDegrees < 180.f))
    throw InvalidArgument("Camera.fovYDegrees", std::to_string(camera.fovYDegrees),
                          "must be in (0, 180)");
  const Vec3f forward = camera.target - camera.eye;
  if (!(norm(forward) > 0.f))
    throw InvalidArgument("Camera.target", "eye", "must differ from Camera.eye");
  if (!(norm(cross(forward, camera.up)) > 1e-6f * norm(forward) * norm(camera.up)))
    throw InvalidArgument("Camera.up", "parallel to view direction",
                          "must not be parallel to target - eye");
}

void SplatRenderer::setGround(float height, float halfSize) {
  if (!std::isfinite(height))
    throw InvalidArgument("setGround.height", std::to_string(height), "must be finite");
  if (!(halfSize > 0.f) || !std::isfinite(halfSize))
    throw InvalidArgument("setGround.halfSize", std::to_string(halfSize),
                          "must be positive and finite");
  hasGround_ = true;
  groundHeight_ = height;
  groundHalfSize_ = halfSize;
}

void SplatRenderer::addParticles(const std::vector<Vec3f>& positions, float radius,
                                 Rgb colour) {
  if (!(radius > 0.f) || !std::isfinite(radius))
    throw InvalidArgument("addParticles.radius", std::to_string(radius),
                          "must be positive and finite");
  batches_.push_back(Batch{positions, radius, colour});
}

void SplatRenderer::clear() { batches_.clear(); }

std::vector<uint8_t> SplatRenderer::render() const {
  const View view = makeView(camera_);
  const int width = view.width, height = view.height;
  std::vector<uint8_t> image(static_cast<size_t>(width) * height * 3);
  std::vector<float> depth(static_cast<size_t>(width) * height,
                           std::numeric_limits<float>::infinity());

  // background pass: sky gradient, or the ground where a pixel's ray meets it
  const float groundLambert =
      std::max(0.f, dot(Vec3f{0.f, 1.f, 0.f}, view.toWorld(view.lightCam)));
  const float groundLight = 0.62f + 0.38f * groundLambert;
  for (int py = 0; py < height; ++py) {
    for (int px = 0; px < width; ++px) {
      const size_t pixel = static_cast<size_t>(py) * width + px;
      const Vec3f ray = view.pixelRay(px, py);
      float colour[3];
      bool onGround = false;
      if (hasGround_ && ray.y != 0.f) {
        const float t = (groundHeight_ - view.eye.y) / ray.y;
        const Vec3f hit = view.eye + t * ray;
        if (t > 0.f && std::fabs(hit.x) <= groundHalfSize_ &&
            std::fabs(hit.z) <= groundHalfSize_) {
          onGround = true;
          depth[pixel] = t;
          const long cell = static_cast<long>(std::floor(hit.x / kCheckerSize)) +
                            static_cast<long>(std::floor(hit.z / kCheckerSize));
          // fade the checks to their mean where a pixel spans a whole square, to avoid moire
          const float rayLength = norm(ray);
          const float footprint =
              t * rayLength / view.focalPixels / std::max(0.05f, std::fabs(ray.y) / rayLength);
          const float contrast = clamp01(1.f - footprint / kCheckerSize);
          const float check = 0.80f + ((cell & 1) ? -0.07f : 0.07f) * contrast;
          for (int c = 0; c < 3; ++c) colour[c] = check * groundLight;
        }
      }
      if (!onGround) skyColour(ray, colour);
      for (int c = 0; c < 3; ++c) image[pixel * 3 + c] = toByte(colour[c]);
    }
  }

  // particle pass: project each centre, bound its disc, test pixels inside against the
  // front surface of the sphere
  for (const Batch& batch : batches_) {
    const float base[3] = {batch.colour.r / 255.f, batch.colour.g / 255.f,
                           batch.colour.b / 255.f};
    const float radius = batch.radius;
    for (const Vec3f& position : batch.positions) {
      const Vec3f d = position - view.eye;
      const float z = dot(d, view.forward);
      if (!(z > kNearPlane)) continue;  // behind the camera (or NaN)
      const float invZ = 1.f / z;
      const float sx = view.centreX + view.focalPixels * dot(d, view.right) * invZ;
      const float sy = view.centreY - view.focalPixels * dot(d, view.up) * invZ;
      // at least half a pixel diagonal, so that a far particle still covers its pixel
      const float discRadius = std::max(view.focalPixels * radius * invZ, 0.7072f);
      const float minX = std::max(sx - discRadius, 0.f);
      const float maxX = std::min(sx + discRadius, static_cast<float>(width) - 1.f);
      const float minY = std::max(sy - discRadius, 0.f);
      const float maxY = std::min(sy + discRadius, static_cast<float>(height) - 1.f);
      if (!(minX <= maxX && minY <= maxY)) continue;  // off screen
      const int x0 = static_cast<int>(minX), x1 = static_cast<int>(maxX);
      const int y0 = static_cast<int>(minY), y1 = static_cast<int>(maxY);
      const float invDisc = 1.f / discRadius;
      for (int py = y0; py <= y1; ++py) {
        const float dy = (static_cast<float>(py) + 0.5f - sy) * invDisc;
        for (int px = x0; px <= x1; ++px) {
          const float dx = (static_cast<float>(px) + 0.5f - sx) * invDisc;
          const float r2 = dx * dx + dy * dy;
          if (r2 > 1.f) continue;
          const float nz = std::sqrt(1.f - r2);
          const float surfaceDepth = z - radius * nz;
          const size_t pixel = static_cast<size_t>(py) * width + px;
          if (!(surfaceDepth < depth[pixel])) continue;
          depth[pixel] = surfaceDepth;
          // sphere normal in camera coordinates; screen y points down, camera up points up
          const Vec3f normal{dx, -dy, -nz};
          const float lambert = std::max(0.f, dot(normal, view.lightCam));
          const float specular = kSpecular * pow32(std::max(0.f, dot(normal, view.halfCam)));
          // slight rim darkening separates touching balls of the same colour
          const float shade = (kAmbient + kDiffuse * lambert) * (0.8f + 0.2f * nz);
          for (int c = 0; c < 3; ++c) image[pixel * 3 + c] = toByte(base[c] * shade + specular);
        }
      }
    }
  }
  return image;
}

void SplatRenderer::writePng(const std::string& path) const {
  const std::vector<uint8_t> image = render();
  std::FILE* file = std::fopen(path.c_str(), "wb");
  if (file == nullptr)
    throw Error("writePng: cannot open '" + path + "' for writing: " + std::strerror(errno));
  PngErrorRecord error{};
  const bool encoded = encodePng(file, image.data(), camera_.width, camera_.height, &error);
  const bool closed = std::fclose(file) == 0;
  if (!encoded) throw Error("writePng: libpng failed on '" + path + "': " + error.message);
  if (!closed) throw Error("writePng: failed writing '" + path + "': " + std::strerror(errno));
}

}  // namespace mpm::io
