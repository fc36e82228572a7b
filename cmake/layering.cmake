# The layers of ARCHITECTURE.md, checked at configure time so that the rule cannot silently break:
#   core <- constraints (the registration)
#   core <- imaging <- data_synth (the phantoms: no inverse crime, nothing of the registration)
#   all of them <- apps/workflow <- apps
# bs_check_layer(<target> FORBIDDEN <target>... INCLUDES <folder>... SOURCES <folder>...) fails the
# configuration when <target>'s link closure contains a forbidden target, or when a source or header
# under the SOURCES folders includes a header from the INCLUDES folders.

# Appends to <out> every target in the link closure of <target> (LINK_LIBRARIES and
# INTERFACE_LINK_LIBRARIES, aliases resolved, generator expressions skipped).
function(bs_link_closure target out)
  set(seen ${${out}})
  set(todo ${target})
  while(todo)
    list(POP_FRONT todo t)
    if(NOT TARGET ${t})
      continue()
    endif()
    get_target_property(aliased ${t} ALIASED_TARGET)
    if(aliased)
      set(t ${aliased})
    endif()
    if(t IN_LIST seen)
      continue()
    endif()
    list(APPEND seen ${t})
    foreach(prop LINK_LIBRARIES INTERFACE_LINK_LIBRARIES)
      get_target_property(deps ${t} ${prop})
      if(deps)
        foreach(d IN LISTS deps)
          string(REGEX REPLACE "^\\$<LINK_ONLY:(.*)>$" "\\1" d "${d}")
          if(NOT d MATCHES "^\\$<")
            list(APPEND todo ${d})
          endif()
        endforeach()
      endif()
    endforeach()
  endwhile()
  set(${out} ${seen} PARENT_SCOPE)
endfunction()

function(bs_check_layer target)
  cmake_parse_arguments(ARG "" "" "FORBIDDEN;INCLUDES;SOURCES" ${ARGN})
  set(closure "")
  bs_link_closure(${target} closure)
  foreach(f IN LISTS ARG_FORBIDDEN)
    if(f IN_LIST closure)
      message(FATAL_ERROR "layering: ${target} links ${f} (directly or through another target); "
                          "see cmake/layering.cmake and ARCHITECTURE.md")
    endif()
  endforeach()
  foreach(dir IN LISTS ARG_SOURCES)
    file(GLOB_RECURSE files ${PROJECT_SOURCE_DIR}/${dir}/*.cpp ${PROJECT_SOURCE_DIR}/${dir}/*.hpp)
    foreach(file IN LISTS files)
      foreach(inc IN LISTS ARG_INCLUDES)
        file(STRINGS ${file} hits REGEX "^[ \t]*#[ \t]*include[ \t]*[\"<]${inc}/")
        if(hits)
          file(RELATIVE_PATH rel ${PROJECT_SOURCE_DIR} ${file})
          message(FATAL_ERROR "layering: ${rel} includes ${hits}: ${dir}/ must not include ${inc}/")
        endif()
      endforeach()
    endforeach()
  endforeach()
endfunction()

bs_check_layer(brainshift_core FORBIDDEN brainshift_constraints brainshift_imaging
               brainshift_data_synth INCLUDES constraints imaging data_synth apps SOURCES core)
bs_check_layer(brainshift_constraints FORBIDDEN brainshift_imaging brainshift_data_synth
               INCLUDES imaging data_synth apps SOURCES constraints)
bs_check_layer(brainshift_imaging FORBIDDEN brainshift_constraints brainshift_data_synth
               INCLUDES constraints data_synth apps SOURCES imaging)
bs_check_layer(brainshift_data_synth FORBIDDEN brainshift_constraints
               INCLUDES constraints apps SOURCES data_synth)

# Inside the registration, the stage folders (start/, pairing/, rows/, loop/, noise/, uncertainty/)
# sit below registration.hpp, the entry points: they include registration_types.hpp, never
# registration.hpp, so that no include runs back up from a stage to the schedule that calls it.
file(GLOB_RECURSE bs_stage_files ${PROJECT_SOURCE_DIR}/constraints/registration/*/*.cpp
     ${PROJECT_SOURCE_DIR}/constraints/registration/*/*.hpp)
foreach(file IN LISTS bs_stage_files)
  file(STRINGS ${file} hits REGEX "^[ \t]*#[ \t]*include[ \t]*\"constraints/registration/registration\\.hpp\"")
  if(hits)
    file(RELATIVE_PATH rel ${PROJECT_SOURCE_DIR} ${file})
    message(FATAL_ERROR "layering: ${rel} includes registration.hpp: a stage folder includes "
                        "registration_types.hpp (see cmake/layering.cmake)")
  endif()
endforeach()
