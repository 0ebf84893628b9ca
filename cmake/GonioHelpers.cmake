# gonio_add_module(<name> [ROOMS ...] [PUBLIC_DEPS ...] [PRIVATE_DEPS ...] [PUBLIC_INCLUDES ...]
#                  [PRIVATE_INCLUDES ...])
# Builds gonio_<name> from <name>/src/*.cpp (and <name>/src/<room>/*.cpp for each of ROOMS, the
# sub-folders of a module that is organised in rooms) with public headers in <name>/include,
# aliased gonio::<name>.
function(gonio_add_module name)
  cmake_parse_arguments(ARG "" "" "ROOMS;PUBLIC_DEPS;PRIVATE_DEPS;PUBLIC_INCLUDES;PRIVATE_INCLUDES" ${ARGN})
  set(patterns ${CMAKE_CURRENT_SOURCE_DIR}/src/*.cpp)
  foreach(room IN LISTS ARG_ROOMS)
    list(APPEND patterns ${CMAKE_CURRENT_SOURCE_DIR}/src/${room}/*.cpp)
  endforeach()
  file(GLOB sources CONFIGURE_DEPENDS ${patterns})
  # Installed and exported as gonio::<name> (cmake/GonioInstall.cmake): the include folders of the
  # build are for the build only; an installed consumer gets the installed include folder, and the
  # package configuration finds the system include folders (PUBLIC_INCLUDES) again.
  set(own_includes $<BUILD_INTERFACE:${CMAKE_CURRENT_SOURCE_DIR}/include>
                   $<BUILD_INTERFACE:${PROJECT_BINARY_DIR}/generated>
                   $<INSTALL_INTERFACE:${CMAKE_INSTALL_INCLUDEDIR}>)
  set(public_includes)
  foreach(dir ${ARG_PUBLIC_INCLUDES})
    list(APPEND public_includes $<BUILD_INTERFACE:${dir}>)
  endforeach()
  set_property(GLOBAL APPEND PROPERTY GONIO_MODULES gonio_${name})
  if(NOT sources)
    # Header-only so far.
    add_library(gonio_${name} INTERFACE)
    add_library(gonio::${name} ALIAS gonio_${name})
    set_target_properties(gonio_${name} PROPERTIES EXPORT_NAME ${name})
    target_include_directories(gonio_${name} SYSTEM INTERFACE ${public_includes})
    target_include_directories(gonio_${name} INTERFACE ${own_includes})
    target_link_libraries(gonio_${name} INTERFACE ${ARG_PUBLIC_DEPS})
    return()
  endif()
  add_library(gonio_${name} STATIC ${sources})
  add_library(gonio::${name} ALIAS gonio_${name})
  if(name IN_LIST gonio_optimised_when_instrumented)
    target_compile_options(gonio_${name} PRIVATE $<$<CONFIG:Instrumented>:-O2>)
  endif()
  target_include_directories(gonio_${name} PUBLIC ${own_includes})
  target_include_directories(gonio_${name} SYSTEM PUBLIC ${public_includes})
  target_include_directories(gonio_${name} SYSTEM PRIVATE ${ARG_PRIVATE_INCLUDES})
  target_link_libraries(gonio_${name} PUBLIC ${ARG_PUBLIC_DEPS}
                        PRIVATE $<BUILD_INTERFACE:gonio_warnings> ${ARG_PRIVATE_DEPS})
  set_target_properties(gonio_${name} PROPERTIES POSITION_INDEPENDENT_CODE ON EXPORT_NAME ${name})
endfunction()

# gonio_add_tests(<module> DEPS ... [CAMERA_STREAMS <label>...] [OFF_STREAM <gtest pattern>...])
# Every tests/<module>/<label>_*_test.cpp joins the executable gonio_<module>_<label>_tests; each GoogleTest
# case becomes its own ctest entry labelled <label> (the module is the name's prefix). The executables of
# the CAMERA_STREAMS labels stream frames through Aravis (a campaign on the virtual rig, a camera
# command): they are labelled "stream" instead and hold RESOURCE_LOCK gige. Run as root, Aravis 0.8
# receives GVSP through a packet socket that sees every loopback datagram until its filter is attached,
# so a stream started beside other loopback traffic can take foreign packets
# (docs/benchmarks/camera.md). scripts/test.sh runs the "stream" tests after the others, one at a time.
# The cases of those executables that match an OFF_STREAM pattern (gtest filter syntax, Suite.* or
# Suite.Case) start no camera (they fit, convert, drive axes over Modbus, or are refused before a
# rig starts): they keep their own label and run beside the other tests.
function(gonio_add_tests module)
  cmake_parse_arguments(ARG "" "" "DEPS;CAMERA_STREAMS;OFF_STREAM" ${ARGN})
  foreach(label unit property stress integration fault)
    file(GLOB sources CONFIGURE_DEPENDS ${CMAKE_CURRENT_SOURCE_DIR}/${label}_*_test.cpp)
    if(sources)
      set(exe gonio_${module}_${label}_tests)
      add_executable(${exe} ${sources})
      target_link_libraries(${exe} PRIVATE ${ARG_DEPS} GTest::gtest_main GTest::gmock gonio_warnings)
      target_compile_definitions(${exe} PRIVATE
        GONIO_SOURCE_DIR="${PROJECT_SOURCE_DIR}" GONIO_BINARY_DIR="${PROJECT_BINARY_DIR}")
      # One label each: gtest_discover_tests hands the properties to its generated script as a flat
      # list, where "a;b" would become two properties, not two labels.
      set(labels "${label}")
      set(lock "")
      if(label IN_LIST ARG_CAMERA_STREAMS)
        set(labels stream)
        set(lock RESOURCE_LOCK gige)
      endif()
      # Instrumented code runs several times slower (the model-selection tests fit dozens of models):
      # the sanitizer build gives every test three times as long.
      set(timeout 300)
      if(GONIO_SANITIZE)
        set(timeout 900)
      endif()
      if(lock AND ARG_OFF_STREAM)
        list(JOIN ARG_OFF_STREAM ":" off_stream)
        gtest_discover_tests(${exe}
          TEST_PREFIX "${module}."
          TEST_FILTER "${off_stream}"
          PROPERTIES LABELS "${label}" TIMEOUT ${timeout}
          DISCOVERY_TIMEOUT 60)
        gtest_discover_tests(${exe}
          TEST_PREFIX "${module}."
          TEST_FILTER "-${off_stream}"
          PROPERTIES LABELS "${labels}" TIMEOUT ${timeout} ${lock}
          DISCOVERY_TIMEOUT 60)
      else()
        gtest_discover_tests(${exe}
          TEST_PREFIX "${module}."
          PROPERTIES LABELS "${labels}" TIMEOUT ${timeout} ${lock}
          DISCOVERY_TIMEOUT 60)
      endif()
    endif()
  endforeach()
endfunction()
