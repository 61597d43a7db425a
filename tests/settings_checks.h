#pragma once
// Bad scene settings: a Scene made from them must refuse them with an InvalidArgument
// that names the field.
#include <gtest/gtest.h>

#include <string>

#include "mpm/error.h"
#include "mpm/scene.h"

namespace mpm::test {

inline void expectSettingsRejected(const SceneSettings& s, const std::string& field) {
  try {
    Scene scene(s);
    ADD_FAILURE() << field << " accepted";
  } catch (const InvalidArgument& e) {
    EXPECT_EQ(e.field(), field) << e.what();
  }
}

}  // namespace mpm::test
