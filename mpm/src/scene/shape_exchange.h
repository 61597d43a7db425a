#pragma once
// The rigid shapes between advances: the scene's records, handed to the backend as bodies
// and parts before an advance and read back from it after.
#include <memory>
#include <vector>

#include "system/sim_backend.h"
#include "scene/particle_seeding.h"
#include "scene/slot_table.h"
#include "shapes/shape_builder.h"
#include "tools/tool_builder.h"
#include "shapes/shape_speed.h"

namespace mpm {

/// A rigid shape as the scene keeps it.
struct ShapeRecord {
  ShapeDesc desc;
  ShapeState state;
  ShapeImpulse lastImpulse;
};
using ShapeTable = SlotTable<ShapeRecord, ShapeId>;

/// A slicer as the scene keeps it (kinematic: its state is the caller's). A curved one has
/// its geometry in `curved` and the common fields in `desc`.
struct SlicerRecord {
  QuadSlicerDesc desc;
  ShapeState state;
  ShapeImpulse lastImpulse;
  std::shared_ptr<const CurvedBlade> curved;
};
using SlicerTable = SlotTable<SlicerRecord, SlicerId>;

/// Where a needle's tip is. Outside the material it is blunt and presses the surface in
/// until it breaks in; inside it opens a track (needleTipResistance); once it has been deep
/// in the material (the half ball ahead of it full), a surface ahead of it is a far one,
/// which the tip presses out blunt again until it breaks out (the second peak of a needle
/// passing through tissue: Frick et al., J Biomech 2001).
enum class TipState : uint8_t {
  kOutside = 0,   ///< blunt: before it breaks in, or pressing a far surface out
  kEntering = 1,  ///< broke in, the material ahead not yet all round it (or breaking out)
  kDeep = 2,      ///< in the material, the half ball ahead of it full at least once
};

/// A curve as the scene keeps it: a needle (its state is the caller's, its tip's state
/// the scene's) or a thread (its points and their velocities the caller's).
struct CurveRecord {
  bool needle = true;
  ArcDesc arc;              ///< a needle's
  LineSegmentsDesc thread;  ///< a thread's, its points and velocities as last set
  ShapeState state;         ///< a needle's
  TipState tip = TipState::kOutside;  ///< a needle's
  bool tipInside() const { return tip != TipState::kOutside; }
  /// Per body: a needle's wire and tip, a thread's segments; about each body's centre (a
  /// needle's frame origin, a segment's midpoint)
  std::vector<ShapeImpulse> impulses;
  /// Per body: the mean mass of the grid nodes in contact over the last advance [kg]
  /// (not kept in checkpoints: empty until the next advance)
  std::vector<float> contactMasses;
  size_t bodyCount() const { return needle ? 2 : thread.points.size() - 1; }
};
using CurveTable = SlotTable<CurveRecord, CurveId>;

/// Refuses `s` for the record's body when it moves faster than the grid can follow
/// (SubstepBounds::maxShapeSpeed under `settings`), naming `prefix`.linearVelocity or
/// .angularVelocity (its rim: the farthest point of the body's geometry; a plane reaches
/// across the domain).
void checkSpeed(const char* prefix, const ShapeRecord& r, const ShapeState& s, const SceneSettings& settings);
void checkSpeed(const char* prefix, const SlicerRecord& r, const ShapeState& s, const SceneSettings& settings);
void checkSpeed(const char* prefix, const CurveRecord& needle, const ShapeState& s, const SceneSettings& settings);

/// Where the scene's shapes, slicers and curves are among the backend's bodies (-1: not
/// there). A slicer is two bodies, its faces at the index given and its spine after them;
/// a curve's bodies (CurveRecord::bodyCount) start at the index given.
struct BodyMap {
  std::vector<int> shapes, slicers, curves;
};

/// The pressure of the material on a needle's shaft per unit density [m^2/s^2]: the
/// track the tip opened is held shut by the material around it, strained by order one
/// where the wire holds it open, so its pressure is about the shear modulus; taken from
/// the stiffest live material (per density: the shaft's friction acts on the grid's mass).
float trackPressurePerDensity(const ObjectTable& objects);

/// Hands the live shapes, then the live slicers, to the backend (bodies in slot order,
/// then parts); returns where each slot's bodies are.
BodyMap uploadShapes(const ShapeTable& shapes, const SlicerTable& slicers, const CurveTable& curves,
                     const ObjectTable& objects, const SceneSettings& settings, SimBackend& backend);

/// Reads the shapes' motion and the shapes' and slicers' impulses back after an advance
/// (`map` from uploadShapes).
/// A needle's tip breaks in when the force on it along its tangent reaches its
/// punctureForce, and is out again when no material lies ahead of it over an advance of
/// `dt`, or blunt again when, deep in the material, a surface comes within its reach (TipState).
void downloadShapes(ShapeTable& shapes, SlicerTable& slicers, CurveTable& curves, const BodyMap& map, float dt,
                    SimBackend& backend);

}  // namespace mpm
