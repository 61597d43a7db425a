#pragma once
// The fastest motion a shape, slicer or curve may be given: the grid follows a moving
// body only a fraction of a cell per substep, so a speed beyond the substep policy's limit
// (SubstepBounds::maxShapeSpeed) is refused where it is given, naming its field, rather
// than by the next advance.
#include <string>
#include <vector>

#include "shapes/shape_builder.h"
#include "tools/tool_builder.h"

namespace mpm {

/// Throws InvalidArgument when `s` moves a point within `reach` [m] of the origin its
/// angular velocity turns about faster than `maxSpeed` [m/s]: `prefix`.linearVelocity
/// when that alone does, else `prefix`.angularVelocity.
void validateSpeed(const std::string& prefix, const ShapeState& s, float reach, float maxSpeed);
/// The same for a thread's points' velocities (LineSegmentsDesc.velocities[i]).
void validateThreadSpeeds(const std::vector<Vec3f>& velocities, float maxSpeed);

/// How far a shape's parts reach from its centre of mass [m]; a plane, `planeReach`.
float reachOf(const ShapeDesc& desc, float planeReach);
/// How far a slicer's blade and spine reach from its frame's origin [m]; a curved one's
/// blade as far as its sampled grid (`curved`).
float reachOf(const QuadSlicerDesc& desc, const CurvedBlade* curved);

}  // namespace mpm
