# Install rules and the exported CMake package: a host application does
#   find_package(lightskin REQUIRED)  and links  lightskin::gi, lightskin::render, ...
include(CMakePackageConfigHelpers)

get_property(modules GLOBAL PROPERTY LIGHTSKIN_MODULES)
install(TARGETS ${modules} lightskin_pcl EXPORT lightskinTargets
  ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR}
  LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR}
  RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR}
  INCLUDES DESTINATION ${CMAKE_INSTALL_INCLUDEDIR})
install(EXPORT lightskinTargets NAMESPACE lightskin:: DESTINATION ${CMAKE_INSTALL_LIBDIR}/cmake/lightskin)

configure_package_config_file(${CMAKE_CURRENT_LIST_DIR}/lightskinConfig.cmake.in
  ${CMAKE_CURRENT_BINARY_DIR}/lightskinConfig.cmake
  INSTALL_DESTINATION ${CMAKE_INSTALL_LIBDIR}/cmake/lightskin)
write_basic_package_version_file(${CMAKE_CURRENT_BINARY_DIR}/lightskinConfigVersion.cmake
  COMPATIBILITY SameMinorVersion)
install(FILES ${CMAKE_CURRENT_BINARY_DIR}/lightskinConfig.cmake
              ${CMAKE_CURRENT_BINARY_DIR}/lightskinConfigVersion.cmake
        DESTINATION ${CMAKE_INSTALL_LIBDIR}/cmake/lightskin)
