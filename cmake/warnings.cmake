# Warnings as an INTERFACE target, linked PRIVATE by every brainshift target.
if(TARGET brainshift_warnings)
  return()
endif()
add_library(brainshift_warnings INTERFACE)
target_compile_options(brainshift_warnings INTERFACE
  -Wall -Wextra -Wpedantic -Wshadow -Wnon-virtual-dtor -Wcast-align -Woverloaded-virtual
  -Wno-deprecated-copy  # Eigen 3.4 headers under GCC 12
  $<$<BOOL:${BS_WERROR}>:-Werror>)
