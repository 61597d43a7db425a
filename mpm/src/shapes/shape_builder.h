#pragma once
// From the public ShapeDesc to the kernels' BodyView and PartViews, with validation.
#include <memory>
#include <string>
#include <vector>

#include "mpm/shapes.h"
#include "contact/rigid_body.h"

namespace mpm {

/// Rotation matrix of a unit quaternion.
Mat3f rotationMatrix(const Quat& q);
/// The rotation taking local x to the direction `d` (unit).
Quat rotationFromX(Vec3f d);
/// Quaternion of a rotation matrix (for reporting poses back).
Quat quaternionFromMatrix(const Mat3f& R);

/// Throws InvalidArgument naming the field for any invalid value of `desc`.
void validateShapeDesc(const ShapeDesc& desc);
/// Throws InvalidArgument for a non-finite pose or velocity, or a zero quaternion.
void validateShapeState(const ShapeState& state);

/// The body of a shape in `state`; a Bonded shape's band is at least `bondedBand` [m].
BodyView makeBody(const ShapeDesc& desc, const ShapeState& state, float bondedBand);
/// Appends the shape's parts for body `bodyIndex`, placed at `state`'s pose and anchored
/// near `near` (world, the domain's centre: PartView); `meshValues(grid)` maps a mesh's
/// grid (its shared_ptr) to the backend's copy of its values. A part thinner than
/// `minHalfThickness` [m] gets the contact band that makes up the difference.
template <class MeshValues>
void appendParts(const ShapeDesc& desc, const ShapeState& state, int bodyIndex, float minHalfThickness, Vec3f near,
                 MeshValues meshValues, std::vector<PartView>& out);

/// The part without its mesh pointer (kept non-template for the .cpp).
PartView makePart(const Geometry& g, const ShapeDesc& desc, const ShapeState& state, int bodyIndex,
                  float minHalfThickness, Vec3f near);

template <class MeshValues>
void appendParts(const ShapeDesc& desc, const ShapeState& state, int bodyIndex, float minHalfThickness, Vec3f near,
                 MeshValues meshValues, std::vector<PartView>& out) {
  for (const Geometry& g : desc.parts) {
    PartView p = makePart(g, desc, state, bodyIndex, minHalfThickness, near);
    if (g.type == GeometryType::Mesh) p.sdfValues = meshValues(g.sdf);
    out.push_back(p);
  }
}

}  // namespace mpm
