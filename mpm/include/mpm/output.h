#pragma once
/// Output a person can look at: particle files for ParaView/Blender, PNG snapshots from a
/// headless splat renderer, and a terminal progress bar. Library `mpm_io`; independent of
/// the solver so that demos and benchmarks share it.
#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "mpm/math.h"

namespace mpm::io {

/// 8-bit RGB colour.
struct Rgb {
  uint8_t r = 200, g = 90, b = 90;
};

/// Points with a colour each and line segments between them (edges: index pairs into
/// `points`): tissue particles, or a needle's arc and a thread as polylines.
struct PlyFrame {
  std::vector<Vec3f> points;
  std::vector<Rgb> colours;                ///< one per point
  std::vector<std::array<int, 2>> edges;  ///< each a pair of indices into `points`
  /// Appends `p` in colour `c` as separate points.
  void addPoints(const std::vector<Vec3f>& p, Rgb c);
  /// Appends `p` in colour `c` joined by an edge from each point to the next.
  void addPolyline(const std::vector<Vec3f>& p, Rgb c);
};

/// Writes `frame` as a binary little-endian PLY: element vertex (x, y, z as float; red,
/// green, blue as uchar), then element edge (vertex1, vertex2 as int) when it has edges.
/// ParaView and Blender open it. Throws mpm::Error naming the path if it cannot be written
/// or an edge names a point it lacks.
void writePly(const std::string& path, const PlyFrame& frame);

/// Writes a binary little-endian PLY point cloud (x, y, z as float; plus vx, vy, vz when
/// `velocities` is given and has the same size). ParaView and Blender open it.
/// Throws mpm::Error naming the path if the file cannot be written.
void writePly(const std::string& path, const std::vector<Vec3f>& positions,
              const std::vector<Vec3f>* velocities = nullptr);


/// Pinhole camera looking from `eye` at `target`.
struct Camera {
  Vec3f eye{2.f, 1.5f, 3.f};
  Vec3f target{0.f, 0.f, 0.f};
  Vec3f up{0.f, 1.f, 0.f};
  float fovYDegrees = 40.f;
  int width = 640;   ///< pixels
  int height = 480;  ///< pixels
};

/// Renders particles as shaded sphere splats (z-buffered, one directional light plus
/// ambient) over an optional ground plane, headless, to PNG.
class SplatRenderer {
 public:
  explicit SplatRenderer(const Camera& camera);
  /// Draws a horizontal ground plane y = height as a light checkerboard, `halfSize` [m].
  void setGround(float height, float halfSize);
  /// Adds particles of world-space radius `radius` [m] in colour `colour`.
  void addParticles(const std::vector<Vec3f>& positions, float radius, Rgb colour);
  /// Removes all particles (keeps camera and ground).
  void clear();
  /// Renders and writes an RGB PNG. Throws mpm::Error naming the path on failure.
  void writePng(const std::string& path) const;
  /// Renders into a width*height*3 RGB buffer (row 0 at the top).
  std::vector<uint8_t> render() const;

 private:
  Camera camera_;
  bool hasGround_ = false;
  float groundHeight_ = 0.f, groundHalfSize_ = 1.f;
  struct Batch {
    std::vector<Vec3f> positions;
    float radius;
    Rgb colour;
  };
  std::vector<Batch> batches_;
};

/// Progress of a long run on the terminal: a redrawn bar on a TTY, plain lines
/// ("label: 40/100 (40%) 3.2 s") at every 10% otherwise, so logs stay readable.
class ProgressBar {
 public:
  ProgressBar(std::string label, long long total);
  /// Reports that `done` of `total` units are finished.
  void update(long long done);
  /// Completes the bar (prints the final line once).
  void finish();
  ~ProgressBar();

 private:
  std::string label_;
  long long total_;
  long long lastPrintedDecile_ = -1;
  bool tty_;
  bool finished_ = false;
  double startSeconds_;
  double lastDrawSeconds_ = -1.0;  ///< steady-clock time of the last TTY redraw [s]
  bool drawnOnTty_ = false;        ///< a bar line is on the terminal and needs ending
};

}  // namespace mpm::io
