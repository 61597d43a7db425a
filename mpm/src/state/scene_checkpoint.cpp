#include "state/scene_checkpoint.h"

#include <cstdio>
#include <string>

#include "mpm/settings_fields.h"
#include "shapes/shape_builder.h"
#include "tools/tool_builder.h"

namespace mpm::checkpoint {

namespace {

using Reason = CheckpointError::Reason;

std::string describe(float v) {
  char b[32];
  std::snprintf(b, sizeof b, "%.9g", v);
  return b;
}
std::string describe(int v) { return std::to_string(v); }
std::string describe(bool v) { return v ? "true" : "false"; }
std::string describe(Vec3f v) { return "(" + describe(v.x) + ", " + describe(v.y) + ", " + describe(v.z) + ")"; }
template <class E, std::enable_if_t<std::is_enum_v<E>, int> = 0>
std::string describe(E v) {
  return describe((int)v);
}

bool sameBits(const void* a, const void* b, size_t n) { return std::memcmp(a, b, n) == 0; }

}  // namespace

void writeSettings(Writer& w, const SceneSettings& s) {
  w.section("settings");
  forEachField(s, [&](const char* name, const auto& value, FieldRole) {
    w.putString(name);
    w.put(value);
  });
}

void checkSettings(Reader& r, const SceneSettings& current) {
  r.section("settings");
  forEachField(current, [&](const char* name, const auto& mine, FieldRole role) {
    using T = std::decay_t<decltype(mine)>;
    if (r.getString("a settings field name") != name)
      throw CheckpointError(Reason::Version, std::string("its settings do not list ") + name + " where this library does");
    const T theirs = r.get<T>(name);
    // bit for bit: a checkpoint resumes the same physics, not a neighbouring one
    if (role == FieldRole::Model && !sameBits(&theirs, &mine, sizeof(T)))
      throw CheckpointError(Reason::OtherScene, std::string("of another scene: its ") + name + " = " + describe(theirs) +
                                                    ", this scene's " + describe(mine));
  });
}

void writeBackendState(Writer& w, const BackendState& s) {
  w.section("particles");
#define MPM_WRITE_FIELD(type, name) \
  w.putString(#name);               \
  w.putArray(s.particles.name);
  MPM_PARTICLE_FIELDS(MPM_WRITE_FIELD)
#undef MPM_WRITE_FIELD
  w.section("meshless");
  w.putArray(s.reference);
  w.putArray(s.cells.points);
  w.putArray(s.cells.volumes);
  w.putArray(s.cells.surfaceStart);
  w.putArray(s.cells.surfacePoints);
  w.putArray(s.cells.surfaceAreas);
  w.putArray(s.cellSlot);
}

void readBackendState(Reader& r, BackendState& s) {
  r.section("particles");
#define MPM_READ_FIELD(type, name)                                                                        \
  if (r.getString("a particle field name") != #name)                                                     \
    throw CheckpointError(Reason::Version, "its particle fields differ from this library's at '" #name "'"); \
  r.getArray(s.particles.name, "particle field " #name);
  MPM_PARTICLE_FIELDS(MPM_READ_FIELD)
#undef MPM_READ_FIELD
  const size_t n = s.particles.x.size();
  bool sameCount = true;
#define MPM_COUNT(type, name) sameCount = sameCount && s.particles.name.size() == n;
  MPM_PARTICLE_FIELDS(MPM_COUNT)
#undef MPM_COUNT
  if (!sameCount) throw CheckpointError(Reason::Truncated, "its particle fields have different lengths");
  r.section("meshless");
  r.getArray(s.reference, "meshless reference positions");
  r.getArray(s.cells.points, "integration cell points");
  r.getArray(s.cells.volumes, "integration cell volumes");
  r.getArray(s.cells.surfaceStart, "integration cell surfaces");
  r.getArray(s.cells.surfacePoints, "integration cell surface points");
  r.getArray(s.cells.surfaceAreas, "integration cell surface areas");
  r.getArray(s.cellSlot, "integration cell objects");
  const bool cellsConsistent = s.cells.volumes.size() == s.cells.points.size() &&
                               s.cellSlot.size() == s.cells.points.size() &&
                               s.cells.surfaceStart.size() == s.cells.points.size() + 1 &&
                               s.cells.surfacePoints.size() == s.cells.surfaceAreas.size() &&
                               s.cells.surfaceStart.back() == s.cells.surfacePoints.size() &&
                               (s.reference.empty() || s.reference.size() == n);
  if (!cellsConsistent) throw CheckpointError(Reason::Truncated, "its meshless model inputs have inconsistent lengths");
}

void writeObjects(Writer& w, const ObjectTable& objects) {
  w.section("objects");
  objects.save(w, [](Writer& out, const ObjectRecord& o) { out.put(o); });
}

void readObjects(Reader& r, ObjectTable& objects) {
  r.section("objects");
  objects.load(r, [](Reader& in) { return in.get<ObjectRecord>("a particle object"); });
}

void writeShapes(Writer& w, const ShapeTable& shapes) {
  w.section("shapes");
  ShapeWriter descs;
  shapes.save(w, [&](Writer& out, const ShapeRecord& s) {
    descs.write(out, s.desc);
    out.put(s.state);
    out.put(s.lastImpulse);
  });
}

namespace {
/// A loaded description must pass the check its add call makes: the file's CRC holds, but a
/// value no add call accepts must not reach the kernels (a mesh part without its grid,
/// found by fuzz_checkpoint, was dereferenced when the shape was built).
template <class Check>
void checkLoaded(const char* what, Check&& check) {
  try {
    check();
  } catch (const InvalidArgument& e) {
    throw CheckpointError(Reason::Malformed, std::string(what) + ": " + e.what());
  }
}
}  // namespace

void readShapes(Reader& r, ShapeTable& shapes) {
  r.section("shapes");
  ShapeReader descs;
  shapes.load(r, [&](Reader& in) {
    ShapeRecord s;
    s.desc = descs.read(in);
    s.state = in.get<ShapeState>("a shape's state");
    s.lastImpulse = in.get<ShapeImpulse>("a shape's impulse");
    checkLoaded("a shape", [&] {
      validateShapeDesc(s.desc);
      validateShapeState(s.state);
    });
    return s;
  });
}

void writeSlicers(Writer& w, const SlicerTable& slicers) {
  w.section("slicers");
  slicers.save(w, [](Writer& out, const SlicerRecord& s) {
    out.put(s.desc);
    out.put(s.state);
    out.put(s.lastImpulse);
    out.put((uint8_t)(s.curved ? 1 : 0));
    if (!s.curved) return;
    const SignedDistanceGrid& g = *s.curved->grid;
    out.put(g.lower);
    out.put(g.cellSize);
    out.put(g.dims);
    out.putArray(g.values);
    out.put(s.curved->spineFrom);
    out.put(s.curved->spineTo);
  });
}

void readSlicers(Reader& r, SlicerTable& slicers) {
  r.section("slicers");
  slicers.load(r, [](Reader& in) {
    SlicerRecord s;
    s.desc = in.get<QuadSlicerDesc>("a slicer");
    s.state = in.get<ShapeState>("a slicer's state");
    s.lastImpulse = in.get<ShapeImpulse>("a slicer's impulse");
    checkLoaded("a slicer", [&] {
      validateSlicerDesc(s.desc);
      validateShapeState(s.state);
    });
    if (in.get<uint8_t>("a slicer's kind") == 0) return s;
    auto grid = std::make_shared<SignedDistanceGrid>();
    grid->lower = in.get<Vec3f>("a curved blade's grid");
    grid->cellSize = in.get<float>("a curved blade's grid");
    in.getInto(grid->dims, "a curved blade's grid");
    in.getArray(grid->values, "a curved blade's grid");
    if ((size_t)grid->dims[0] * grid->dims[1] * grid->dims[2] != grid->values.size())
      throw CheckpointError(CheckpointError::Reason::Truncated, "a curved blade's grid does not match its size");
    auto curved = std::make_shared<CurvedBlade>();
    curved->grid = std::move(grid);
    curved->spineFrom = in.get<Vec3f>("a curved blade's spine");
    curved->spineTo = in.get<Vec3f>("a curved blade's spine");
    s.curved = std::move(curved);
    return s;
  });
}

void writeCurves(Writer& w, const CurveTable& curves) {
  w.section("curves");
  curves.save(w, [](Writer& out, const CurveRecord& c) {
    out.put((uint8_t)(c.needle ? 1 : 0));
    out.put(c.arc);
    out.put(c.state);
    out.put((uint8_t)c.tip);
    const LineSegmentsDesc& t = c.thread;
    out.putArray(t.points);
    out.putArray(t.velocities);
    out.put(t.radius);
    out.put(t.friction);
    out.put(t.drag);
    out.put(t.linearDensity);
    out.put(t.gravity);
    out.putArray(c.impulses);
  });
}

void readCurves(Reader& r, CurveTable& curves) {
  r.section("curves");
  curves.load(r, [](Reader& in) {
    CurveRecord c;
    c.needle = in.get<uint8_t>("a curve's kind") != 0;
    c.arc = in.get<ArcDesc>("a needle");
    c.state = in.get<ShapeState>("a needle's state");
    const uint8_t tip = in.get<uint8_t>("a needle's tip");
    if (tip > (uint8_t)TipState::kDeep)
      throw CheckpointError(CheckpointError::Reason::Malformed, "a needle's tip state is " + std::to_string(tip) + ", none of 0, 1, 2");
    c.tip = (TipState)tip;
    LineSegmentsDesc& t = c.thread;
    in.getArray(t.points, "a thread's points");
    in.getArray(t.velocities, "a thread's velocities");
    t.radius = in.get<float>("a thread");
    t.friction = in.get<float>("a thread");
    t.drag = in.get<float>("a thread");
    t.linearDensity = in.get<float>("a thread");
    t.gravity = in.get<Vec3f>("a thread");
    in.getArray(c.impulses, "a curve's impulses");
    checkLoaded("a curve", [&] {
      if (c.needle) {
        validateCurveDesc(c.arc);
        validateShapeState(c.state);
      } else {
        validateCurveDesc(t);
      }
    });
    if ((!c.needle && t.points.size() < 2) || c.impulses.size() != c.bodyCount())
      throw CheckpointError(CheckpointError::Reason::Truncated, "a curve's points do not match its impulses");
    return c;
  });
}

void checkParticles(const BackendState& s, const ObjectTable& objects, bool meshless, const GridGeometry* grid) {
  std::vector<size_t> count(objects.size(), 0);
  const HostParticles& p = s.particles;
  for (size_t i = 0; i < p.size(); ++i) {
    if (grid) {
      const Vec3f x = p.x[i];
      bool inside = true;
      for (int a = 0; a < 3; ++a)
        inside = inside && x[a] >= grid->lower[a] && x[a] <= grid->lower[a] + grid->cells[a] * grid->dx;
      if (!inside || !grid->stencilInside(x))  // (NaN fails the comparisons)
        throw CheckpointError(Reason::Malformed, "particle " + std::to_string(i) + " lies outside the grid, at (" +
                                                     std::to_string(x.x) + ", " + std::to_string(x.y) + ", " +
                                                     std::to_string(x.z) + ")");
    }
    const uint32_t o = p.object[i];
    if (o >= objects.size() || !objects.alive(o) || p.local[i] >= objects[o].particles)
      throw CheckpointError(Reason::Truncated, "particle " + std::to_string(i) + " names no live object (slot " +
                                                   std::to_string(o) + ", index " + std::to_string(p.local[i]) + ")");
    count[o]++;
  }
  for (size_t o = 0; o < objects.size(); ++o)
    if (objects.alive(o) && count[o] != objects[o].particles)
      throw CheckpointError(Reason::Truncated, "object slot " + std::to_string(o) + " has " + std::to_string(count[o]) +
                                                   " particles, its record says " + std::to_string(objects[o].particles));
  if (meshless != (s.reference.size() == p.size() && !p.x.empty()) && !p.x.empty())
    throw CheckpointError(Reason::Truncated, meshless ? "its meshless nodes have no reference positions"
                                                      : "it holds meshless reference positions for a grid solver");
}

namespace {

// The plain fields of a part, a shape and a mesh grid, once for writing and reading:
// f(field, what) for each (what names it in a refusal).
template <class G, class F>
void partFields(G& g, F&& f) {
  f(g.type, "a part's type");
  f(g.halfExtents, "a part's half extents");
  f(g.radius, "a part's radius");
  f(g.halfHeight, "a part's half height");
  f(g.axis, "a part's axis");
  f(g.localPose, "a part's local pose");
}
template <class D, class F>
void shapeFields(D& d, F&& f) {
  f(d.pose, "a shape's pose");
  f(d.linearVelocity, "a shape's velocity");
  f(d.angularVelocity, "a shape's angular velocity");
  f(d.centerOfMass, "a shape's centre of mass");
  f(d.contact, "a shape's contact");
  f(d.mass, "a shape's mass");
  f(d.inertia, "a shape's inertia");
  f(d.gravity, "a shape's gravity");
}
template <class S, class F>
void gridFields(S& s, F&& f) {
  f(s.lower, "a mesh grid's corner");
  f(s.cellSize, "a mesh grid's cell");
  f(s.dims, "a mesh grid's size");
  f(s.signReliable, "a mesh grid's sign flag");
}

}  // namespace

void ShapeWriter::write(Writer& w, const ShapeDesc& d) {
  w.put((uint64_t)d.parts.size());
  const auto put = [&](const auto& field, const char*) { w.put(field); };
  for (const Geometry& g : d.parts) {
    partFields(g, put);
    // the grid: -1 none, k an earlier one, else written here as the next index
    int32_t index = -1;
    if (g.sdf) {
      for (size_t k = 0; k < written_.size() && index < 0; ++k)
        if (written_[k] == g.sdf.get()) index = (int32_t)k;
      if (index < 0) {
        w.put((int32_t)written_.size());
        gridFields(*g.sdf, put);
        w.putArray(g.sdf->values);
        w.putString(g.sdf->signWarning);
        written_.push_back(g.sdf.get());
        continue;
      }
    }
    w.put(index);
  }
  shapeFields(d, put);
}

ShapeDesc ShapeReader::read(Reader& r) {
  ShapeDesc d;
  const auto get = [&](auto& field, const char* what) { r.getInto(field, what); };
  const uint64_t nParts = r.get<uint64_t>("a shape's part count");
  for (uint64_t p = 0; p < nParts; ++p) {
    Geometry g;
    partFields(g, get);
    const int32_t index = r.get<int32_t>("a part's mesh grid");
    if (index == (int32_t)read_.size()) {
      auto grid = std::make_shared<SignedDistanceGrid>();
      gridFields(*grid, get);
      r.getArray(grid->values, "a mesh grid's values");
      grid->signWarning = r.getString("a mesh grid's warning");
      if ((uint64_t)grid->dims[0] * (uint64_t)grid->dims[1] * (uint64_t)grid->dims[2] != grid->values.size())
        throw CheckpointError(Reason::Truncated, "a mesh grid's values do not fill its size");
      read_.push_back(grid);
      g.sdf = grid;
    } else if (index >= 0) {
      if (index > (int32_t)read_.size()) throw CheckpointError(Reason::Truncated, "a part names a mesh grid not yet read");
      g.sdf = read_[(size_t)index];
    }
    d.parts.push_back(g);
  }
  shapeFields(d, get);
  return d;
}

}  // namespace mpm::checkpoint
