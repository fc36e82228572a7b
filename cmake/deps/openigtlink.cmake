# OpenIGTLink (Debian libopenigtlink-dev, 1.11: protocol 2, the 58-byte header): `brainshift
# serve` (apps/serve). Debian's OpenIGTLinkConfig.cmake defines no imported target (only
# variables and compiler flags meant for its own build), so the library and headers are found
# directly.
if(TARGET OpenIGTLink::OpenIGTLink)
  return()
endif()
find_path(OpenIGTLink_INCLUDE_DIR igtlImageMessage.h PATH_SUFFIXES openigtlink REQUIRED)
find_library(OpenIGTLink_LIBRARY NAMES OpenIGTLink REQUIRED)
add_library(OpenIGTLink::OpenIGTLink UNKNOWN IMPORTED)
set_target_properties(OpenIGTLink::OpenIGTLink PROPERTIES
  IMPORTED_LOCATION "${OpenIGTLink_LIBRARY}"
  INTERFACE_SYSTEM_INCLUDE_DIRECTORIES "${OpenIGTLink_INCLUDE_DIR}"
  INTERFACE_INCLUDE_DIRECTORIES "${OpenIGTLink_INCLUDE_DIR}")
