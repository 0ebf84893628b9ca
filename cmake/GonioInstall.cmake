# Install rules, the CMake package, the pkg-config file and the generated layout headers. Included
# by the top-level CMakeLists.txt after every module, so that the module list and the Python
# package folder are known. docs/install.md describes the installed tree.
include(CMakePackageConfigHelpers)

set(GONIO_INSTALL_DATADIR "${CMAKE_INSTALL_DATADIR}/gonio")
set(GONIO_INSTALL_LIBEXECDIR "${CMAKE_INSTALL_LIBEXECDIR}/gonio")
set(GONIO_INSTALL_CMAKEDIR "${CMAKE_INSTALL_LIBDIR}/cmake/gonio")

# --- The layout seen from an installed binary (base/src/data_path.cpp, tools/main.cpp) ---------
# Relative paths only: the tree works at any prefix. A fake root stands for the prefix.
function(gonio_relative out from to)
  file(RELATIVE_PATH rel "/gonio-prefix/${from}" "/gonio-prefix/${to}")
  if(rel STREQUAL "")
    set(rel ".")
  endif()
  set(${out} "${rel}" PARENT_SCOPE)
endfunction()
set(data_from "${CMAKE_INSTALL_BINDIR}" "${GONIO_INSTALL_LIBEXECDIR}")
if(GONIO_BUILD_PYTHON)
  list(APPEND data_from "${GONIO_PYTHON_INSTALL_DIR}/gonio")
endif()
set(GONIO_LAYOUT_DATA_DIRS "")
foreach(from ${data_from})
  gonio_relative(rel "${from}" "${GONIO_INSTALL_DATADIR}")
  if(NOT GONIO_LAYOUT_DATA_DIRS MATCHES "\"${rel}\"")
    string(APPEND GONIO_LAYOUT_DATA_DIRS "\"${rel}\", ")
  endif()
endforeach()
gonio_relative(to_libexec "${CMAKE_INSTALL_BINDIR}" "${GONIO_INSTALL_LIBEXECDIR}")
gonio_relative(to_bin "${GONIO_INSTALL_LIBEXECDIR}" "${CMAKE_INSTALL_BINDIR}")
set(GONIO_LAYOUT_FULL_DIRS "\"${to_libexec}\", \"${to_bin}\"")
configure_file(${PROJECT_SOURCE_DIR}/cmake/install_layout.h.in
               ${PROJECT_BINARY_DIR}/generated-private/install_layout.h @ONLY)

# --- The commit behind `gonio --version` (configure time; a new commit reconfigures) -----------
set(GONIO_GIT_COMMIT "unknown")
set(GONIO_COMMIT_TEXT "commit unknown: not built from a git checkout")
find_package(Git QUIET)
if(GIT_FOUND)
  execute_process(COMMAND ${GIT_EXECUTABLE} rev-parse HEAD WORKING_DIRECTORY ${PROJECT_SOURCE_DIR}
                  OUTPUT_VARIABLE commit OUTPUT_STRIP_TRAILING_WHITESPACE ERROR_QUIET RESULT_VARIABLE rc)
  if(rc EQUAL 0 AND commit)
    set(GONIO_GIT_COMMIT "${commit}")
    set(GONIO_COMMIT_TEXT "commit ${commit}")
    execute_process(COMMAND ${GIT_EXECUTABLE} describe --tags --dirty WORKING_DIRECTORY ${PROJECT_SOURCE_DIR}
                    OUTPUT_VARIABLE describe OUTPUT_STRIP_TRAILING_WHITESPACE ERROR_QUIET RESULT_VARIABLE rc)
    if(rc EQUAL 0 AND describe)
      string(APPEND GONIO_COMMIT_TEXT ", ${describe}")
    else()
      execute_process(COMMAND ${GIT_EXECUTABLE} diff-index --quiet HEAD --
                      WORKING_DIRECTORY ${PROJECT_SOURCE_DIR} RESULT_VARIABLE rc ERROR_QUIET)
      if(NOT rc EQUAL 0)
        string(APPEND GONIO_COMMIT_TEXT ", with uncommitted changes")
      endif()
    endif()
    execute_process(COMMAND ${GIT_EXECUTABLE} rev-parse --absolute-git-dir
                    WORKING_DIRECTORY ${PROJECT_SOURCE_DIR} OUTPUT_VARIABLE git_dir
                    OUTPUT_STRIP_TRAILING_WHITESPACE ERROR_QUIET)
    foreach(f HEAD logs/HEAD)
      if(EXISTS "${git_dir}/${f}")
        set_property(DIRECTORY ${PROJECT_SOURCE_DIR} APPEND PROPERTY CMAKE_CONFIGURE_DEPENDS "${git_dir}/${f}")
      endif()
    endforeach()
  endif()
endif()
configure_file(${PROJECT_SOURCE_DIR}/cmake/build_info.h.in
               ${PROJECT_BINARY_DIR}/generated-private/build_info.h @ONLY)

# --- Programs, data, docs, examples --------------------------------------------------------------
install(TARGETS gonio gonio-full RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR})
install(DIRECTORY ${PROJECT_SOURCE_DIR}/data/ DESTINATION ${GONIO_INSTALL_DATADIR})
install(DIRECTORY ${PROJECT_SOURCE_DIR}/examples DESTINATION ${GONIO_INSTALL_DATADIR})
install(DIRECTORY ${PROJECT_SOURCE_DIR}/packaging/udev DESTINATION ${GONIO_INSTALL_DATADIR})
install(PROGRAMS ${PROJECT_SOURCE_DIR}/packaging/gonio-device-access DESTINATION ${GONIO_INSTALL_DATADIR})
install(DIRECTORY ${PROJECT_SOURCE_DIR}/docs/ DESTINATION ${CMAKE_INSTALL_DOCDIR})
install(FILES ${PROJECT_SOURCE_DIR}/README.md ${PROJECT_SOURCE_DIR}/LICENSE DESTINATION ${CMAKE_INSTALL_DOCDIR})

# --- Libraries, headers and the CMake package ----------------------------------------------------
get_property(gonio_modules GLOBAL PROPERTY GONIO_MODULES)
install(TARGETS ${gonio_modules} EXPORT gonioTargets
        ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR})
foreach(module ${gonio_modules})
  get_target_property(dir ${module} SOURCE_DIR)
  install(DIRECTORY ${dir}/include/ DESTINATION ${CMAKE_INSTALL_INCLUDEDIR})
endforeach()
install(FILES ${PROJECT_BINARY_DIR}/generated/gonio/version.h DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}/gonio)
install(EXPORT gonioTargets NAMESPACE gonio:: DESTINATION ${GONIO_INSTALL_CMAKEDIR})
configure_package_config_file(${PROJECT_SOURCE_DIR}/cmake/gonioConfig.cmake.in
                              ${PROJECT_BINARY_DIR}/gonioConfig.cmake
                              INSTALL_DESTINATION ${GONIO_INSTALL_CMAKEDIR}
                              PATH_VARS GONIO_INSTALL_DATADIR)
write_basic_package_version_file(${PROJECT_BINARY_DIR}/gonioConfigVersion.cmake
                                 COMPATIBILITY SameMinorVersion)
install(FILES ${PROJECT_BINARY_DIR}/gonioConfig.cmake ${PROJECT_BINARY_DIR}/gonioConfigVersion.cmake
        DESTINATION ${GONIO_INSTALL_CMAKEDIR})

# --- pkg-config: the BRDF and fitting core (the device modules are for CMake consumers) ----------
gonio_relative(GONIO_PC_TO_PREFIX "${CMAKE_INSTALL_LIBDIR}/pkgconfig" ".")
configure_file(${PROJECT_SOURCE_DIR}/cmake/gonio.pc.in ${PROJECT_BINARY_DIR}/gonio.pc @ONLY)
install(FILES ${PROJECT_BINARY_DIR}/gonio.pc DESTINATION ${CMAKE_INSTALL_LIBDIR}/pkgconfig)

# --- Man pages: gonio(1) and gonio-COMMAND(1), generated from the programs' --help ---------------
file(GLOB command_sources ${PROJECT_SOURCE_DIR}/tools/cmd_*.cpp)
set(gonio_commands)
set(man_pages ${PROJECT_BINARY_DIR}/man/gonio.1)
foreach(f ${command_sources})
  get_filename_component(c ${f} NAME_WE)
  string(REGEX REPLACE "^cmd_" "" c "${c}")
  list(APPEND gonio_commands ${c})
  list(APPEND man_pages ${PROJECT_BINARY_DIR}/man/gonio-${c}.1)
endforeach()
add_custom_command(
  OUTPUT ${man_pages}
  COMMAND ${CMAKE_COMMAND} -E make_directory ${PROJECT_BINARY_DIR}/man
  COMMAND ${CMAKE_COMMAND} -DGONIO=$<TARGET_FILE:gonio> -DOUT=${PROJECT_BINARY_DIR}/man
          -DVERSION=${PROJECT_VERSION} "-DCOMMANDS=${gonio_commands}"
          -P ${PROJECT_SOURCE_DIR}/cmake/GonioManPages.cmake
  DEPENDS gonio gonio-full ${PROJECT_SOURCE_DIR}/cmake/GonioManPages.cmake
  COMMENT "man pages from gonio --help" VERBATIM)
add_custom_target(gonio_man ALL DEPENDS ${man_pages})
install(FILES ${man_pages} DESTINATION ${CMAKE_INSTALL_MANDIR}/man1)
