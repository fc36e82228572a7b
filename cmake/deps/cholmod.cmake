# Debian 12 ships SuiteSparse 5.x without CMake config files: locate CHOLMOD directly
# and expose it as the imported target SuiteSparse::CHOLMOD.
if(TARGET SuiteSparse::CHOLMOD)
  return()
endif()
find_path(CHOLMOD_INCLUDE_DIR cholmod.h PATH_SUFFIXES suitesparse REQUIRED)
find_library(CHOLMOD_LIBRARY cholmod REQUIRED)
find_library(SUITESPARSECONFIG_LIBRARY suitesparseconfig REQUIRED)
add_library(SuiteSparse::CHOLMOD UNKNOWN IMPORTED)
set_target_properties(SuiteSparse::CHOLMOD PROPERTIES
  IMPORTED_LOCATION "${CHOLMOD_LIBRARY}"
  INTERFACE_INCLUDE_DIRECTORIES "${CHOLMOD_INCLUDE_DIR}"
  INTERFACE_LINK_LIBRARIES "${SUITESPARSECONFIG_LIBRARY}")
message(STATUS "CHOLMOD: ${CHOLMOD_LIBRARY}")
