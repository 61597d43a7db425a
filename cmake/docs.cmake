# The API reference: `cmake --build BUILD --target docs` runs Doxygen over the public
# headers (docs/Doxyfile.in) into BUILD/docs/api. Defined only when Doxygen is found;
# scripts/test.sh builds it and says so loudly when Doxygen is missing.
find_package(Doxygen QUIET)
if(DOXYGEN_FOUND)
  set(MPM_DOCS_OUT ${PROJECT_BINARY_DIR}/docs/api)
  configure_file(${PROJECT_SOURCE_DIR}/docs/Doxyfile.in ${MPM_DOCS_OUT}/Doxyfile @ONLY)
  add_custom_target(docs
    COMMAND ${DOXYGEN_EXECUTABLE} ${MPM_DOCS_OUT}/Doxyfile
    COMMAND ${CMAKE_COMMAND} -E echo "API reference: ${MPM_DOCS_OUT}/html/index.html (warnings: ${MPM_DOCS_OUT}/warnings.log)"
    WORKING_DIRECTORY ${PROJECT_SOURCE_DIR}
    COMMENT "Doxygen: the public headers' API reference"
    VERBATIM)
endif()
