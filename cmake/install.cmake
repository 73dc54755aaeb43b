# cmake --install: the tools (tools/CMakeLists.txt), libpf static and shared, the headers under
# include/pf/, pkg-config's pf.pc, the CMake package (find_package(pf) gives pf::pf) and the docs.
include(CMakePackageConfigHelpers)

install(TARGETS pf EXPORT pfTargets
        LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR}
        ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR}
        RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR})
# The static library is not in the export set: its private dependencies (OSMesa, CHOLMOD, Embree,
# ...) have no CMake packages on Debian; `pkg-config --static --libs pf` lists them.
install(TARGETS pfcore ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR})
install(DIRECTORY ${PROJECT_SOURCE_DIR}/libcore/include/pf
        DESTINATION ${CMAKE_INSTALL_INCLUDEDIR} FILES_MATCHING PATTERN "*.h")
install(FILES ${PROJECT_BINARY_DIR}/libcore/include/pf/version.h
        DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}/pf)

set(PF_CMAKE_DIR ${CMAKE_INSTALL_LIBDIR}/cmake/pf)
install(EXPORT pfTargets NAMESPACE pf:: DESTINATION ${PF_CMAKE_DIR})
configure_package_config_file(${PROJECT_SOURCE_DIR}/cmake/pfConfig.cmake.in
                              ${PROJECT_BINARY_DIR}/pfConfig.cmake INSTALL_DESTINATION ${PF_CMAKE_DIR})
# 0.x: a minor version may change the API, so only the same minor version is compatible.
write_basic_package_version_file(${PROJECT_BINARY_DIR}/pfConfigVersion.cmake
                                 VERSION ${PROJECT_VERSION} COMPATIBILITY SameMinorVersion)
install(FILES ${PROJECT_BINARY_DIR}/pfConfig.cmake ${PROJECT_BINARY_DIR}/pfConfigVersion.cmake
        DESTINATION ${PF_CMAKE_DIR})

# pf.pc with paths relative to its own place (${pcfiledir}), so a moved prefix still works.
file(RELATIVE_PATH PF_PC_TO_PREFIX ${CMAKE_INSTALL_FULL_LIBDIR}/pkgconfig ${CMAKE_INSTALL_PREFIX})
configure_file(${PROJECT_SOURCE_DIR}/cmake/pf.pc.in ${PROJECT_BINARY_DIR}/pf.pc @ONLY)
install(FILES ${PROJECT_BINARY_DIR}/pf.pc DESTINATION ${CMAKE_INSTALL_LIBDIR}/pkgconfig)

# The documentation: the README, docs/*.md (the scene keys, the stream format, the library) and
# the example program, under share/doc/pf.
file(GLOB PF_DOCS ${PROJECT_SOURCE_DIR}/docs/*.md)
install(FILES ${PROJECT_SOURCE_DIR}/README.md ${PF_DOCS} ${PROJECT_SOURCE_DIR}/docs/example.c
        DESTINATION ${CMAKE_INSTALL_DOCDIR})
