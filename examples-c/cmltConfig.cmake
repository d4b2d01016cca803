# CMake package of cmlt's C API, installed by `make -C examples-c install`
# into PREFIX/lib/cmake/cmlt/. In a project:
#   find_package(cmlt 0.1 REQUIRED)                  # -DCMAKE_PREFIX_PATH=PREFIX
#   target_link_libraries(app PRIVATE cmlt::cmlt)    # the static library
#   target_link_libraries(app PRIVATE cmlt::shared)  # or the shared one
# Both targets carry the include directory (cmlt.h, cmlt.hpp); the static
# one also the system libraries Rust's standard library needs.
get_filename_component(_cmlt_prefix "${CMAKE_CURRENT_LIST_DIR}/../../.." ABSOLUTE)
if(NOT TARGET cmlt::cmlt)
  add_library(cmlt::cmlt STATIC IMPORTED)
  set_target_properties(cmlt::cmlt PROPERTIES
    IMPORTED_LOCATION "${_cmlt_prefix}/lib/libcmlt.a"
    INTERFACE_INCLUDE_DIRECTORIES "${_cmlt_prefix}/include"
    INTERFACE_LINK_LIBRARIES "gcc_s;util;rt;pthread;m;dl;c")
endif()
if(NOT TARGET cmlt::shared)
  add_library(cmlt::shared SHARED IMPORTED)
  set_target_properties(cmlt::shared PROPERTIES
    IMPORTED_LOCATION "${_cmlt_prefix}/lib/libcmlt.so"
    IMPORTED_NO_SONAME TRUE
    INTERFACE_INCLUDE_DIRECTORIES "${_cmlt_prefix}/include")
endif()
unset(_cmlt_prefix)
