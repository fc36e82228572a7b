if(TARGET opencv_core)
  return()
endif()
find_package(OpenCV 4 REQUIRED COMPONENTS core imgproc imgcodecs)
