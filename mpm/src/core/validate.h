#pragma once
// Input checks shared by every public entry point. Each throws InvalidArgument naming the
// field and the offending value, before anything is changed.
#include <string>
#include <string_view>

#include "mpm/error.h"
#include "mpm/settings.h"

namespace mpm::validate {

std::string show(float v);
std::string show(Vec3f v);

/// Finite number. (`field` as a view: these run on every advance, so its name becomes a
/// string only for the error.)
void finite(std::string_view field, float v);
void finite(std::string_view field, Vec3f v);
/// Finite and > 0.
void positive(std::string_view field, float v);
void positive(std::string_view field, Vec3f v);
/// Integer >= lo.
void atLeast(const std::string& field, int v, int lo);
/// An enum's value is one of its `count` enumerators 0 .. count - 1 (a cast from an int
/// may hold any value, which a switch would silently read as some other choice).
void enumerator(const std::string& field, int v, int count, const char* type);
template <class Enum>
void enumerator(const std::string& field, Enum v, Enum last, const char* type) {
  enumerator(field, static_cast<int>(v), static_cast<int>(last) + 1, type);
}

void sceneSettings(const SceneSettings& s);
void mtledSettings(const MtledSettings& m);
void material(const std::string& prefix, const Material& m);
void particleObjectDesc(const ParticleObjectDesc& d);

}  // namespace mpm::validate
