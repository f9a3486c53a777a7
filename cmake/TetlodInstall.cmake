# Install rules in one place: the CLI (tools/), every library, the public
# headers (each <dir>/include/tetlod tree plus the generated ones), the CMake
# package (tetlodConfig.cmake, version file, targets under the tetlod:: namespace)
# and tetlod.pc for pkg-config. Included last from the top-level CMakeLists, once
# every target exists; optional converters are installed when they were built.
include(CMakePackageConfigHelpers)

set(TETLOD_INSTALL_CMAKEDIR ${CMAKE_INSTALL_LIBDIR}/cmake/tetlod)

# Dependency order (a library before what it links), so the pkg-config link line
# below works for static archives too. `tetlod` is the umbrella (api/).
set(TETLOD_EXPORTED_TARGETS tetlod tetlod_container_write tetlod_analysis tetlod_codecs tetlod_models tetlod_format
  tetlod_volume_formats tetlod_vdb_io tetlod_hdf5_io tetlod_volume_io tetlod_mesh_io
  tetlod_surface_io tetlod_core)
set(_tetlod_present)
foreach(target IN LISTS TETLOD_EXPORTED_TARGETS)
  if(TARGET ${target})
    list(APPEND _tetlod_present ${target})
    # Build-tree include paths are BUILD_INTERFACE only; installed users find
    # every header under <prefix>/include.
    target_include_directories(${target} PUBLIC $<INSTALL_INTERFACE:${CMAKE_INSTALL_INCLUDEDIR}>)
  endif()
endforeach()
set(TETLOD_EXPORTED_TARGETS ${_tetlod_present})

install(TARGETS ${TETLOD_EXPORTED_TARGETS} EXPORT tetlodTargets
  ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR}
  LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR}
  RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR})
install(EXPORT tetlodTargets NAMESPACE tetlod:: DESTINATION ${TETLOD_INSTALL_CMAKEDIR})

# Public headers: every include/ folder holding a tetlod/ tree, and the
# configured headers (version.hpp, converters/features.hpp).
file(GLOB _tetlod_include_dirs LIST_DIRECTORIES true
  ${PROJECT_SOURCE_DIR}/*/include ${PROJECT_SOURCE_DIR}/*/*/include)
foreach(dir IN LISTS _tetlod_include_dirs)
  if(IS_DIRECTORY ${dir}/tetlod AND NOT dir MATCHES "/(tests|bench|fuzz|build[^/]*)/")
    # hdf5_mpi.hpp and hdf5_mpi_write.hpp belong to tetlod-mpi's private reader
    # and writer (not installed).
    install(DIRECTORY ${dir}/ DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}
      FILES_MATCHING PATTERN "*.hpp" PATTERN "hdf5_mpi.hpp" EXCLUDE PATTERN "hdf5_mpi_write.hpp" EXCLUDE)
  endif()
endforeach()
foreach(dir ${PROJECT_BINARY_DIR}/api/generated ${PROJECT_BINARY_DIR}/converters/volume_formats/generated)
  install(DIRECTORY ${dir}/ DESTINATION ${CMAKE_INSTALL_INCLUDEDIR} FILES_MATCHING PATTERN "*.hpp")
endforeach()

# The package config: find_dependency for what the exported link interfaces
# name. Static archives carry their private dependencies ($<LINK_ONLY:...>), so
# the libraries they link privately are needed too.
set(TETLOD_CONFIG_WITH_OPENMESH 0)
if(TARGET tetlod_surface_io)
  set(TETLOD_CONFIG_WITH_OPENMESH 1)
endif()
set(TETLOD_CONFIG_WITH_OPENVDB_STATIC 0)
if(TARGET tetlod_vdb_io)
  get_target_property(_vdb_type tetlod_vdb_io TYPE)
  if(_vdb_type STREQUAL "STATIC_LIBRARY")
    set(TETLOD_CONFIG_WITH_OPENVDB_STATIC 1)
  endif()
endif()
configure_package_config_file(${PROJECT_SOURCE_DIR}/cmake/tetlodConfig.cmake.in
  ${PROJECT_BINARY_DIR}/cmake/tetlodConfig.cmake
  INSTALL_DESTINATION ${TETLOD_INSTALL_CMAKEDIR})
write_basic_package_version_file(${PROJECT_BINARY_DIR}/cmake/tetlodConfigVersion.cmake
  VERSION ${PROJECT_VERSION} COMPATIBILITY SameMinorVersion)
install(FILES ${PROJECT_BINARY_DIR}/cmake/tetlodConfig.cmake
  ${PROJECT_BINARY_DIR}/cmake/tetlodConfigVersion.cmake
  DESTINATION ${TETLOD_INSTALL_CMAKEDIR})

# pkg-config: libraries in link order, then the third-party libraries the
# archives need (shared ones carry their own dependencies).
set(TETLOD_PC_LIBS "")
foreach(target IN LISTS TETLOD_EXPORTED_TARGETS)
  string(APPEND TETLOD_PC_LIBS " -l${target}")
endforeach()
# Libraries the targets link by file (xxhash, HDF5 and its dependencies).
set(TETLOD_PC_PRIVATE_LIBS "")
set(_tetlod_pc_files)
foreach(target IN LISTS TETLOD_EXPORTED_TARGETS)
  get_target_property(_links ${target} LINK_LIBRARIES)
  foreach(lib IN LISTS _links)
    if(IS_ABSOLUTE "${lib}" AND NOT lib IN_LIST _tetlod_pc_files)
      list(APPEND _tetlod_pc_files ${lib})
      string(APPEND TETLOD_PC_PRIVATE_LIBS " ${lib}")
    endif()
  endforeach()
endforeach()
if(TARGET tetlod_surface_io)
  string(APPEND TETLOD_PC_PRIVATE_LIBS " -lOpenMeshCore")
endif()
if(TETLOD_CONFIG_WITH_OPENVDB_STATIC)
  string(APPEND TETLOD_PC_PRIVATE_LIBS " -lopenvdb")
endif()
file(RELATIVE_PATH TETLOD_PC_TO_PREFIX /prefix/${CMAKE_INSTALL_LIBDIR}/pkgconfig /prefix)
configure_file(${PROJECT_SOURCE_DIR}/cmake/tetlod.pc.in ${PROJECT_BINARY_DIR}/cmake/tetlod.pc @ONLY)
install(FILES ${PROJECT_BINARY_DIR}/cmake/tetlod.pc DESTINATION ${CMAKE_INSTALL_LIBDIR}/pkgconfig)
