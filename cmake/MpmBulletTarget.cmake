# mpm::bullet: Bullet as one imported target with absolute paths. Used by the build
# (bullet_bridge/CMakeLists.txt) and by the installed package (mpm_bulletConfig.cmake).
find_package(Bullet REQUIRED)

# find_package(Bullet) runs CMake's FindBullet module here, which gives absolute paths
# (/usr/include/bullet; BulletDynamics, BulletCollision, LinearMath, BulletSoftBody). Debian
# also ships a BulletConfig.cmake, used when a project asks for CONFIG mode, whose folders
# are relative to BULLET_ROOT_DIR and whose libraries are bare names. Either way, wrap the
# result in one imported target with absolute paths.
if(NOT TARGET mpm::bullet)
  set(_mpm_bullet_includes "")
  foreach(_dir IN LISTS BULLET_INCLUDE_DIRS)
    if(NOT IS_ABSOLUTE "${_dir}" AND DEFINED BULLET_ROOT_DIR)
      set(_dir "${BULLET_ROOT_DIR}/${_dir}")
    endif()
    list(APPEND _mpm_bullet_includes "${_dir}")
  endforeach()
  set(_mpm_bullet_hints "")
  foreach(_dir IN LISTS BULLET_LIBRARY_DIRS)
    if(NOT IS_ABSOLUTE "${_dir}" AND DEFINED BULLET_ROOT_DIR)
      set(_dir "${BULLET_ROOT_DIR}/${_dir}")
    endif()
    list(APPEND _mpm_bullet_hints "${_dir}")
  endforeach()
  set(_mpm_bullet_libraries "")
  foreach(_lib IN LISTS BULLET_LIBRARIES)
    if(_lib MATCHES "^(optimized|debug|general)$" OR IS_ABSOLUTE "${_lib}")
      list(APPEND _mpm_bullet_libraries "${_lib}")
    else()
      find_library(MPM_BULLET_LIB_${_lib} NAMES ${_lib} HINTS ${_mpm_bullet_hints} REQUIRED)
      list(APPEND _mpm_bullet_libraries "${MPM_BULLET_LIB_${_lib}}")
    endif()
  endforeach()
  add_library(mpm::bullet INTERFACE IMPORTED)
  target_include_directories(mpm::bullet INTERFACE ${_mpm_bullet_includes})
  target_link_libraries(mpm::bullet INTERFACE ${_mpm_bullet_libraries})
  if(BULLET_DEFINITIONS)
    target_compile_options(mpm::bullet INTERFACE ${BULLET_DEFINITIONS})
  endif()
endif()
