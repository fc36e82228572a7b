if(TARGET VTK::CommonCore)
  return()
endif()
find_package(VTK 9 REQUIRED COMPONENTS
  CommonCore CommonDataModel IOXML IOImage IOLegacy ImagingCore FiltersCore FiltersGeneral)
