# ISA-L's igzip (Debian: libisal-dev), optional: with it the .nii.gz outputs are deflated about 4x
# faster than by zlib at level 1 (docs/history/BENCHMARKS_NOTEBOOK.md "Speed"); without it zlib deflates them.
# Either way the files decompress to the same bytes. Exposed as the imported target ISAL::isal.
if(TARGET ISAL::isal)
  return()
endif()
find_path(ISAL_INCLUDE_DIR isa-l/igzip_lib.h)
find_library(ISAL_LIBRARY isal)
if(ISAL_INCLUDE_DIR AND ISAL_LIBRARY)
  add_library(ISAL::isal UNKNOWN IMPORTED)
  set_target_properties(ISAL::isal PROPERTIES
    IMPORTED_LOCATION "${ISAL_LIBRARY}"
    INTERFACE_INCLUDE_DIRECTORIES "${ISAL_INCLUDE_DIR}")
  message(STATUS "ISA-L: ${ISAL_LIBRARY}")
else()
  message(STATUS "ISA-L: not found (libisal-dev): .nii.gz outputs are deflated by zlib")
endif()
