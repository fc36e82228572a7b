if(TARGET benchmark::benchmark)
  return()
endif()
find_package(benchmark REQUIRED)
