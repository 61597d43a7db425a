# `cmake --install` puts the libraries, the public headers and a package config in place,
# so that a project says
#   find_package(mpm_bullet CONFIG REQUIRED)
#   target_link_libraries(app PRIVATE mpm_bullet::bullet_bridge)   # or mpm_bullet::mpm alone
# (tests/package checks it). The libraries are static: their private dependencies (Eigen,
# zlib, libpng, assimp, OpenMP, the CUDA runtime) are found again by the package config.
include(CMakePackageConfigHelpers)

install(TARGETS mpm_validate mpm_geometry mpm mpm_io mpm_bullet mpm_scene_file
        EXPORT mpm_bulletTargets
        ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR}
        INCLUDES DESTINATION ${CMAKE_INSTALL_INCLUDEDIR})
install(DIRECTORY ${PROJECT_SOURCE_DIR}/mpm/include/mpm ${PROJECT_SOURCE_DIR}/bullet_bridge/include/mpm_bullet
        DESTINATION ${CMAKE_INSTALL_INCLUDEDIR})
install(FILES ${PROJECT_SOURCE_DIR}/LICENSE DESTINATION ${CMAKE_INSTALL_DATADIR}/doc/mpm_bullet)

set(_mpm_package_dir ${CMAKE_INSTALL_LIBDIR}/cmake/mpm_bullet)
install(EXPORT mpm_bulletTargets NAMESPACE mpm_bullet:: DESTINATION ${_mpm_package_dir})
# what the package config must find again: the options this tree was built with
set(MPM_PACKAGE_WITH_CUDA ${MPM_WITH_CUDA})
set(MPM_PACKAGE_WITH_OPENMP ${MPM_WITH_OPENMP})
configure_package_config_file(${PROJECT_SOURCE_DIR}/cmake/mpm_bulletConfig.cmake.in
                              ${PROJECT_BINARY_DIR}/mpm_bulletConfig.cmake
                              INSTALL_DESTINATION ${_mpm_package_dir})
write_basic_package_version_file(${PROJECT_BINARY_DIR}/mpm_bulletConfigVersion.cmake
                                 COMPATIBILITY SameMinorVersion)
install(FILES ${PROJECT_BINARY_DIR}/mpm_bulletConfig.cmake ${PROJECT_BINARY_DIR}/mpm_bulletConfigVersion.cmake
              ${PROJECT_SOURCE_DIR}/cmake/MpmBulletTarget.cmake
        DESTINATION ${_mpm_package_dir})
