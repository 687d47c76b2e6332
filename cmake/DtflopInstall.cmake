# Installing dtflop: `cmake --install build [--prefix P]` puts
#   bin/dtflop                              the command
#   lib/libdtflop_*.a                       every library of ours (static)
#   include/dtflop/<folder>/*.hpp           their public headers, included as "model/profile.hpp"
#   lib/cmake/dtflop/                       the exported targets: find_package(dtflop) gives
#                                           dtflop::dtflop_model, dtflop::dtflop_workloads, ...
#   share/dtflop/examples/h200.json         a probed H200 profile to predict with
# and `cpack -G DEB` (in the build folder) makes a Debian package of the same files.
# examples/predict is a project built against the installed package (tests/install checks it).
include(CMakePackageConfigHelpers)

get_property(DTFLOP_ALL_LIBS GLOBAL PROPERTY DTFLOP_LIBRARIES)
install(TARGETS dtflop RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR})
install(TARGETS ${DTFLOP_ALL_LIBS} EXPORT dtflopTargets
        ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR}
        INCLUDES DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}/dtflop)
foreach(dir model cuda probes workloads calibrate tune sar reports sources)
  install(DIRECTORY ${PROJECT_SOURCE_DIR}/${dir}/ DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}/dtflop/${dir}
          FILES_MATCHING PATTERN "*.hpp" PATTERN "*.cuh")
endforeach()
install(FILES ${PROJECT_SOURCE_DIR}/docs/examples/h200.json DESTINATION ${CMAKE_INSTALL_DATADIR}/dtflop/examples)

set(DTFLOP_CMAKE_DIR ${CMAKE_INSTALL_LIBDIR}/cmake/dtflop)
install(EXPORT dtflopTargets NAMESPACE dtflop:: DESTINATION ${DTFLOP_CMAKE_DIR})
configure_package_config_file(${PROJECT_SOURCE_DIR}/cmake/dtflopConfig.cmake.in
                              ${PROJECT_BINARY_DIR}/dtflopConfig.cmake INSTALL_DESTINATION ${DTFLOP_CMAKE_DIR})
write_basic_package_version_file(${PROJECT_BINARY_DIR}/dtflopConfigVersion.cmake
                                 VERSION ${PROJECT_VERSION} COMPATIBILITY SameMinorVersion)
install(FILES ${PROJECT_BINARY_DIR}/dtflopConfig.cmake ${PROJECT_BINARY_DIR}/dtflopConfigVersion.cmake
              ${PROJECT_SOURCE_DIR}/cmake/DtflopNccl.cmake
        DESTINATION ${DTFLOP_CMAKE_DIR})

# The Debian package: cpack -G DEB in the build folder. Its dependencies are worked out from
# the shared libraries bin/dtflop links (dpkg-shlibdeps), plus the -dev packages a C++ user of
# the exported targets needs.
set(CPACK_PACKAGE_NAME dtflop)
set(CPACK_PACKAGE_VENDOR "dtflop")
set(CPACK_PACKAGE_DESCRIPTION_SUMMARY
    "Predict, measure and tune computation time on a machine (the DTFLOP model)")
set(CPACK_PACKAGE_VERSION ${PROJECT_VERSION})
set(CPACK_PACKAGE_CONTACT "dtflop maintainers")
set(CPACK_GENERATOR DEB)
set(CPACK_PACKAGING_INSTALL_PREFIX /usr)
set(CPACK_DEBIAN_FILE_NAME DEB-DEFAULT)
set(CPACK_DEBIAN_PACKAGE_SHLIBDEPS ON)
set(CPACK_DEBIAN_PACKAGE_SECTION science)
set(CPACK_DEBIAN_PACKAGE_DEPENDS "libeigen3-dev, libfmt-dev, nlohmann-json3-dev, libopencv-dev, libceres-dev, libnanoflann-dev, libyaml-cpp-dev")
if(DTFLOP_HAVE_MPI)
  string(APPEND CPACK_DEBIAN_PACKAGE_DEPENDS ", libopenmpi-dev, openmpi-bin")
endif()
include(CPack)
