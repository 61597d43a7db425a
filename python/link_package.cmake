# cmake -DSRC=python/mpm_bullet -DDST=build/python/mpm_bullet -P link_package.cmake:
# links every .py file of SRC into DST (the compiled module is built there).
file(MAKE_DIRECTORY ${DST})
file(GLOB _files RELATIVE ${SRC} ${SRC}/*.py)
foreach(f IN LISTS _files)
  if(NOT EXISTS ${DST}/${f})
    file(CREATE_LINK ${SRC}/${f} ${DST}/${f} SYMBOLIC)
  endif()
endforeach()
