#pragma once
// From the public slicer and curve descriptions to the kernels' bodies and parts, with
// validation: blades (blade_builder.cpp), needles (needle_builder.cpp) and threads
// (thread_builder.cpp).
#include <memory>
#include <vector>

#include "mpm/curves.h"
#include "mpm/sdf_grid.h"
#include "mpm/slicers.h"
#include "contact/rigid_body.h"

namespace mpm {

/// Throws InvalidArgument naming the field for any invalid value of a slicer.
void validateSlicerDesc(const QuadSlicerDesc& desc);
/// Throws InvalidArgument naming the field for any invalid value of a curved slicer
/// (its mesh is checked when its grid is built).
void validateSlicerDesc(const MeshSlicerDesc& desc);
/// The common fields of a curved slicer, as the quad's (halfLength and width unused).
QuadSlicerDesc commonFields(const MeshSlicerDesc& desc);

/// A curved blade's geometry: its sampled sided distance (buildBladeGrid), the backend's
/// copy of its values, and its spine's axis in the slicer's frame.
struct CurvedBlade {
  std::shared_ptr<const SignedDistanceGrid> grid;
  Vec3f spineFrom, spineTo;
};

/// A slicer as two kinematic bodies, appended to `bodies` and `parts`: its blade's faces
/// (frictional; a kPartBlade, or with `curved` a kPartCurvedBlade whose values are
/// `curvedValues`, grown by `faceBand` [m] on each face) and its spine (a sticky capsule;
/// none for a curved blade of spine radius 0). Anchored near `near` as makePart anchors.
void appendSlicer(const QuadSlicerDesc& desc, const ShapeState& state, float faceBand, Vec3f near,
                  const CurvedBlade* curved, const float* curvedValues, std::vector<BodyView>& bodies,
                  std::vector<PartView>& parts);

/// Throws InvalidArgument naming the field for any invalid value of a curve.
void validateCurveDesc(const ArcDesc& desc);
void validateCurveDesc(const LineSegmentsDesc& desc);
/// A thread's points and velocities (as validateCurveDesc checks them), for `count` points.
void validateCurvePoints(const std::vector<Vec3f>& points, const std::vector<Vec3f>& velocities, size_t count);

/// Radius of a needle's contact region about its centre line, in cells.
constexpr float kCurveReach = 0.75f;

/// Radius of a thread's contact region about its centre line, in cells. A particle takes
/// its velocity from the 27 nodes about it, and only those within the band move with the
/// thread: a particle on a thread's centre line gets as little as 44 % of its weight from
/// the band at 0.75 dx (the quadratic B-spline, the line anywhere in the cell), so tissue
/// pressed against a pulled thread streamed through it (a stitch pulled up at 1 cm/s
/// stalled at 4.4 mm of its 7.25 mm gap, the thread sliding through the tissue at 0.2 N).
/// At 1.5 dx the band carries at least 98.5 % of it (87 % half a cell off the line): the
/// stitch closed to 2.5 mm at 0.8 N (tests/test_suturing_bullet.cpp, PullingTheStitch).
/// The cost: the thread drags the tissue within 1.5 dx of it sideways, as a wire that
/// thick would, and holds that many more nodes (its added mass).
constexpr float kThreadReach = 1.5f;

/// Reach of a needle's blunt tip (before it breaks in) about its point, in cells. A
/// particle moves with the 27 nodes about it (the quadratic B-spline's 1.5 dx), so a tip
/// holding only the nodes within 0.75 dx of its point moved the particles ahead of it
/// slower than itself: they slipped past it by interpolation, one node layer at a time,
/// and the force on the tip rose and fell with each (0.05-0.27 N over 19 mm into a 50 kPa
/// block, dx 2.5 mm): it never pressed the surface in to a surgical puncture force. At
/// 1.5 dx the particles it touches move with it, the surface dimples and the force rises
/// steadily (to 1 N over 5-6 mm) until the tip breaks in (tests/test_needle_puncture.cpp).
constexpr float kTipReach = 1.5f;

/// Radius about a needle's centre line within which its shaft's friction reaches the
/// nodes, in cells (PartView::frictionReach: enough nodes across it that their sum does not
/// flicker as the wire moves between them).
constexpr float kShaftFrictionReach = 1.5f;

/// A needle as two bodies, appended to `bodies` and `parts`: its wire (kContactCurve, a
/// kPartArc whose shaft friction takes the material's pressure on the wire as
/// `trackPressurePerDensity` [m^2/s^2] times its density) and its tip (a blunt sticky
/// sphere whose contact reaches kTipReach dx, or with `tipInside` a kPartTipInside), at
/// `state` (of the arc's frame).
void appendNeedle(const ArcDesc& desc, const ShapeState& state, bool tipInside, float minHalfThickness, float dx,
                  float trackPressurePerDensity, Vec3f near, std::vector<BodyView>& bodies, std::vector<PartView>& parts);
/// A thread as one body per segment (kContactCurve capsules) through `points` moving at
/// `velocities` (empty: at rest).
void appendThread(const LineSegmentsDesc& desc, const std::vector<Vec3f>& points, const std::vector<Vec3f>& velocities,
                  float minHalfThickness, Vec3f near, std::vector<BodyView>& bodies, std::vector<PartView>& parts);

}  // namespace mpm
