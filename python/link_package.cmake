# cmake -DSRC=python/mpm_bullet -DDST=build/python/mpm_bullet -P link_package.cmake:
# links every .py file and subpackage (a folder with an __init__.py) of SRC into DST (the
# compiled module is built there).
file(MAKE_DIRECTORY ${DST})
file(GLOB _files RELATIVE ${SRC} ${SRC}/*.py ${SRC}/*/__init__.py)
foreach(f IN LISTS _files)
  string(REGEX REPLACE "/__init__.py$" "" f "${f}")
  if(NOT EXISTS ${DST}/${f})
    file(CREATE_LINK ${SRC}/${f} ${DST}/${f} SYMBOLIC)
  endif()
endforeach()
