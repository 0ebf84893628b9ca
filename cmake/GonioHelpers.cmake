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

# Camera-streaming tests (a campaign on the virtual rig, a camera command, Aravis's own camera) run as
# root, where Aravis 0.8 receives GVSP through a packet socket that sees every loopback datagram until
# its filter is attached, and GigE Vision control uses the fixed UDP port 3956 on 127.0.0.1. Where this
# machine lets a test have a network namespace of its own (root: tests/netns-run.sh), each such test
# runs in one and they run in parallel like every other test; elsewhere they hold RESOURCE_LOCK gige
# and run one at a time. gonio_stream_test_properties(<var>) gives the properties for either case and
# gonio_isolate_network(<target>) makes a test executable's cases (and their discovery) run through
# the launcher.
if(NOT DEFINED GONIO_TEST_NETNS)
  execute_process(COMMAND ${PROJECT_SOURCE_DIR}/tests/netns-run.sh true
                  RESULT_VARIABLE gonio_netns_result OUTPUT_QUIET ERROR_QUIET)
  if(gonio_netns_result EQUAL 0)
    set(gonio_netns_default ON)
  else()
    set(gonio_netns_default OFF)
  endif()
  set(GONIO_TEST_NETNS ${gonio_netns_default} CACHE BOOL
      "Run camera-streaming tests each in a network namespace of its own (needs root)")
endif()
set(GONIO_NETNS_LAUNCHER ${PROJECT_SOURCE_DIR}/tests/netns-run.sh)

# GONIO_BUILD_STREAM_TESTS=OFF leaves the camera-streaming test executables out of the build (the
# instrumented CI build runs them once, in the gcc build, and does not compile them).
option(GONIO_BUILD_STREAM_TESTS "Build the camera-streaming tests (campaigns on the virtual rig)" ON)

function(gonio_stream_test_properties out)
  if(GONIO_TEST_NETNS)
    set(${out} "" PARENT_SCOPE)
  else()
    set(${out} RESOURCE_LOCK gige PARENT_SCOPE)
  endif()
endfunction()

function(gonio_isolate_network target)
  if(GONIO_TEST_NETNS)
    set_target_properties(${target} PROPERTIES CROSSCOMPILING_EMULATOR ${GONIO_NETNS_LAUNCHER})
  endif()
endfunction()

# gonio_add_tests(<module> DEPS ... [CAMERA_STREAMS <label>...])
# Every tests/<module>/<label>_*_test.cpp joins the executable gonio_<module>_<label>_tests; each GoogleTest
# case becomes its own ctest entry labelled <label> (the module is the name's prefix). The executables of
# the CAMERA_STREAMS labels stream frames through Aravis: their cases are labelled "stream" instead and
# run each in a network namespace of its own (or one at a time, see above). Which tests stream is a
# property of their file (its label), not a list of names.
function(gonio_add_tests module)
  cmake_parse_arguments(ARG "" "" "DEPS;CAMERA_STREAMS" ${ARGN})
  gonio_stream_test_properties(stream_properties)
  foreach(label unit property stress integration fault)
    file(GLOB sources CONFIGURE_DEPENDS ${CMAKE_CURRENT_SOURCE_DIR}/${label}_*_test.cpp)
    if(label IN_LIST ARG_CAMERA_STREAMS AND NOT GONIO_BUILD_STREAM_TESTS)
      continue()
    endif()
    if(sources)
      set(exe gonio_${module}_${label}_tests)
      add_executable(${exe} ${sources})
      set_target_properties(${exe} PROPERTIES UNITY_BUILD ${GONIO_UNITY_TESTS} UNITY_BUILD_BATCH_SIZE 8)
      target_link_libraries(${exe} PRIVATE ${ARG_DEPS} GTest::gtest_main GTest::gmock gonio_warnings)
      target_include_directories(${exe} PRIVATE ${PROJECT_SOURCE_DIR}/tests)
      target_compile_definitions(${exe} PRIVATE
        GONIO_SOURCE_DIR="${PROJECT_SOURCE_DIR}" GONIO_BINARY_DIR="${PROJECT_BINARY_DIR}")
      # One label each: gtest_discover_tests hands the properties to its generated script as a flat
      # list, where "a;b" would become two properties, not two labels.
      set(labels "${label}")
      set(extra "")
      if(label IN_LIST ARG_CAMERA_STREAMS)
        set(labels stream)
        set(extra ${stream_properties})
        gonio_isolate_network(${exe})
      endif()
      # Instrumented code runs several times slower (the model-selection tests fit dozens of models):
      # the sanitizer build gives every test three times as long.
      set(timeout 300)
      if(GONIO_SANITIZE)
        set(timeout 900)
      endif()
      gtest_discover_tests(${exe}
        TEST_PREFIX "${module}."
        PROPERTIES LABELS "${labels}" TIMEOUT ${timeout} ${extra}
        DISCOVERY_TIMEOUT 60)
    endif()
  endforeach()
endfunction()
