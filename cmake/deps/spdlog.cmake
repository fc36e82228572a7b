if(TARGET spdlog::spdlog)
  return()
endif()
find_package(spdlog REQUIRED)
