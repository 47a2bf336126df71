# What `cmake --install` and `cpack -G DEB` install (docs/api.md "Linking",
# README "Install"): libffd.so.0 and libffd.a, include/ffd*.h, ffd.pc, the
# CMake package ffd (ffdConfig.cmake: ffd::ffd, the shared library, and
# ffd::ffd_static), the ffd command (and ffd-mpi, built with FFD_MPI: the root
# CMakeLists.txt installs both), the editor's page (web/dist, when built)
# under share/ffd/web and the example meshes under share/ffd/examples.
include(CMakePackageConfigHelpers)

install(TARGETS ffd_shared ffd EXPORT ffdTargets
        LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR}
        ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR}
        INCLUDES DESTINATION ${CMAKE_INSTALL_INCLUDEDIR})
file(GLOB FFD_PUBLIC_HEADERS ${CMAKE_SOURCE_DIR}/include/ffd*.h)
install(FILES ${FFD_PUBLIC_HEADERS} DESTINATION ${CMAKE_INSTALL_INCLUDEDIR})

# pkg-config: -lffd links the shared library; the private dependencies are for
# `pkg-config --static` (libffd.a). Named as libraries, not Requires.private:
# pkg-config would demand lapacke.pc and libcjson.pc (the -dev packages) even
# for the shared library
set(FFD_PC_LIBS_PRIVATE "-llapacke -lcjson -lqhull_r -lcholmod -lsuitesparseconfig -lopenblas -lz -lm ${OpenMP_C_FLAGS}")
file(RELATIVE_PATH FFD_PC_TO_PREFIX ${CMAKE_INSTALL_FULL_LIBDIR}/pkgconfig ${CMAKE_INSTALL_PREFIX})
string(REGEX REPLACE "/$" "" FFD_PC_TO_PREFIX "${FFD_PC_TO_PREFIX}")
configure_file(${CMAKE_SOURCE_DIR}/cmake/ffd.pc.in ${CMAKE_BINARY_DIR}/ffd.pc @ONLY)
install(FILES ${CMAKE_BINARY_DIR}/ffd.pc DESTINATION ${CMAKE_INSTALL_LIBDIR}/pkgconfig)

set(FFD_CMAKE_DIR ${CMAKE_INSTALL_LIBDIR}/cmake/ffd)
install(EXPORT ffdTargets NAMESPACE ffd:: DESTINATION ${FFD_CMAKE_DIR})
configure_package_config_file(${CMAKE_SOURCE_DIR}/cmake/ffdConfig.cmake.in
                              ${CMAKE_BINARY_DIR}/ffdConfig.cmake INSTALL_DESTINATION ${FFD_CMAKE_DIR})
write_basic_package_version_file(${CMAKE_BINARY_DIR}/ffdConfigVersion.cmake
                                 VERSION ${PROJECT_VERSION} COMPATIBILITY SameMajorVersion)
install(FILES ${CMAKE_BINARY_DIR}/ffdConfig.cmake ${CMAKE_BINARY_DIR}/ffdConfigVersion.cmake
        DESTINATION ${FFD_CMAKE_DIR})

# the page is a build output of web/ (npm run build): installed when it exists
# at install time; without it `ffd serve` warns at start
install(DIRECTORY ${CMAKE_SOURCE_DIR}/web/dist/ DESTINATION ${CMAKE_INSTALL_DATADIR}/ffd/web OPTIONAL
        PATTERN "*.map" EXCLUDE)
install(CODE "if(NOT EXISTS \"${CMAKE_SOURCE_DIR}/web/dist/index.html\")
  message(WARNING \"web/dist is not built: the editor's page is not installed (cd web && npm ci && npm run build)\")
endif()")
install(DIRECTORY ${CMAKE_SOURCE_DIR}/examples/ DESTINATION ${CMAKE_INSTALL_DATADIR}/ffd/examples)

# Debian package: `cpack -G DEB` in the build directory (README "Install")
set(CPACK_PACKAGE_NAME ffdkit)
set(CPACK_PACKAGE_VERSION ${PROJECT_VERSION})
set(CPACK_PACKAGE_CONTACT "ffdkit developers <ffdkit@localhost>")
set(CPACK_PACKAGE_DESCRIPTION_SUMMARY "free-form deformation of 3D meshes: libffd, the ffd command and its editor")
set(CPACK_PACKAGING_INSTALL_PREFIX /usr)
set(CPACK_DEBIAN_FILE_NAME DEB-DEFAULT)
set(CPACK_DEBIAN_PACKAGE_SECTION graphics)
set(CPACK_DEBIAN_PACKAGE_DESCRIPTION "${CPACK_PACKAGE_DESCRIPTION_SUMMARY}
 Lattice FFD with direct manipulation, point-based FFD (PB-FFD), generalized
 FFD (GFFD) and T-spline proxy FFD of OBJ, PLY, OFF, STL and glTF meshes,
 written back losslessly. The package holds the library (shared and static),
 its header ffd.h, ffd.pc and the CMake package ffd, the ffd command with its
 man pages (and ffd-mpi, which deforms a partitioned mesh over MPI, when built
 with Open MPI), the editor's page for `ffd serve` and the example meshes.")
set(CPACK_STRIP_FILES ON) # the executable and the shared library, as Debian ships them
find_program(FFD_DPKG_SHLIBDEPS dpkg-shlibdeps)
if(FFD_DPKG_SHLIBDEPS)
  set(CPACK_DEBIAN_PACKAGE_SHLIBDEPS ON)
else()
  # Debian 12's runtime packages of the libraries libffd and ffd link
  set(CPACK_DEBIAN_PACKAGE_DEPENDS "libc6, libgomp1, liblapacke, libopenblas0, libcjson1, libqhull-r8.0, libcholmod3, libsuitesparseconfig5, libmicrohttpd12, zlib1g")
  if(FFD_MPI)
    string(APPEND CPACK_DEBIAN_PACKAGE_DEPENDS ", libopenmpi3") # ffd-mpi (docs/mpi.md)
  endif()
endif()
# gzip the man pages; copyright and changelog.gz in /usr/share/doc/ffdkit
set(CPACK_PRE_BUILD_SCRIPTS ${CMAKE_SOURCE_DIR}/cmake/deb_fixups.cmake)
set(CPACK_FFD_SOURCE_DIR ${CMAKE_SOURCE_DIR})
include(CPack)
