# GDCM (Debian libgdcm-dev): DICOM series read and written (imaging/io/dicom_io.cpp).
if(TARGET gdcmMSFF)
  return()
endif()
find_package(GDCM 3 REQUIRED)
