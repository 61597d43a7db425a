#pragma once
// Input checks shared by every public entry point. Each throws InvalidArgument naming the
// field and the offending value, before anything is changed.
#include <string>

#include "mpm/error.h"
#include "mpm/settings.h"

namespace mpm::validate {

std::string show(float v);
std::string show(Vec3f v);

/// Finite number.
void finite(const std::string& field, float v);
void finite(const std::string& field, Vec3f v);
/// Finite and > 0.
void positive(const std::string& field, float v);
void positive(const std::string& field, Vec3f v);
/// Integer >= lo.
void atLeast(const std::string& field, int v, int lo);

void sceneSettings(const SceneSettings& s);
void mtledSettings(const MtledSettings& m);
void material(const std::string& prefix, const Material& m);
void particleObjectDesc(const ParticleObjectDesc& d);

}  // namespace mpm::validate
