if(TARGET Ceres::ceres)
  return()
endif()
find_package(Ceres REQUIRED)
