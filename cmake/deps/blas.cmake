# The BLAS and LAPACK under CHOLMOD (and Ceres): OpenBLAS (Debian: libopenblas-pthread-dev) when
# present, the imported target BS::blas (empty without it).
#
# Why it is linked explicitly: Debian's Ceres config lists ATLAS's libf77blas and libatlas by full
# path, and the first library in the executable's dependencies that defines dgemm_ serves every
# library of the process, CHOLMOD included. That was ATLAS's libf77blas, whatever the system's
# libblas.so.3 alternative said (so swapping the alternative or LD_LIBRARY_PATH changed only
# dpotrf_: docs/BENCHMARKS.md, "BLAS under CHOLMOD, idle"). With OpenBLAS it replaces those two in Ceres'
# link interface and comes first in CHOLMOD's, so it serves BLAS and LAPACK to the whole process.
# Measured on the 2-core VM: the 58k-DOF factorisation 5.3 s (ATLAS) → 1.9-2.4 s (OpenBLAS, one
# thread), `prepare --refine 2.6` 27 → 18-20 s. BS_BLAS=system keeps the libraries Ceres lists.
set(BS_BLAS "auto" CACHE STRING "BLAS under CHOLMOD: auto (OpenBLAS if found), openblas, system")
set_property(CACHE BS_BLAS PROPERTY STRINGS auto openblas system)
if(TARGET BS::blas)
  return()
endif()
add_library(BS::blas INTERFACE IMPORTED)
if(BS_BLAS STREQUAL "system")
  message(STATUS "BLAS: the system's (BS_BLAS=system)")
  return()
endif()
find_library(OPENBLAS_LIBRARY NAMES openblas)
if(NOT OPENBLAS_LIBRARY)
  if(BS_BLAS STREQUAL "openblas")
    message(FATAL_ERROR "BS_BLAS=openblas but libopenblas was not found (libopenblas-pthread-dev)")
  endif()
  message(STATUS "BLAS: OpenBLAS not found (libopenblas-pthread-dev): the system's")
  return()
endif()
set_target_properties(BS::blas PROPERTIES
  INTERFACE_LINK_LIBRARIES "${OPENBLAS_LIBRARY}"
  INTERFACE_COMPILE_DEFINITIONS BRAINSHIFT_HAVE_OPENBLAS=1)
# OpenBLAS first in CHOLMOD's link interface, and in place of the BLAS and LAPACK in Ceres'.
get_target_property(_bs_cholmod_libs SuiteSparse::CHOLMOD INTERFACE_LINK_LIBRARIES)
set_target_properties(SuiteSparse::CHOLMOD PROPERTIES
  INTERFACE_LINK_LIBRARIES "${OPENBLAS_LIBRARY};${_bs_cholmod_libs}")
if(TARGET Ceres::ceres)
  get_target_property(_bs_ceres_target Ceres::ceres ALIASED_TARGET)
  if(NOT _bs_ceres_target)
    set(_bs_ceres_target Ceres::ceres)
  endif()
  get_target_property(_bs_ceres_libs ${_bs_ceres_target} INTERFACE_LINK_LIBRARIES)
  if(_bs_ceres_libs)
    # OpenBLAS holds LAPACK too: the generic liblapack / libblas (the system's alternatives) go as
    # well, so that nothing ahead of OpenBLAS in the executable's dependencies defines dgemm_.
    list(FILTER _bs_ceres_libs EXCLUDE REGEX "/lib(f77blas|atlas|cblas|lapack|blas)\\.(so|a)$")
    set_target_properties(${_bs_ceres_target} PROPERTIES
      INTERFACE_LINK_LIBRARIES "${OPENBLAS_LIBRARY};${_bs_ceres_libs}")
  endif()
endif()
message(STATUS "BLAS: OpenBLAS ${OPENBLAS_LIBRARY}")
