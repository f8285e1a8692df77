# mimic_add_library(<name> [PUBLIC_DEPS ...] [PRIVATE_DEPS ...])
# One library per module folder: include/ is PUBLIC, src/ (all .cpp, recursively) is PRIVATE.
function(mimic_warnings target)
  target_compile_options(${target} PRIVATE -Wall -Wextra -Wpedantic -Wshadow -Wconversion
    -Wno-sign-conversion -Wnon-virtual-dtor -Wold-style-cast -Woverloaded-virtual)
  if(MIMIC_NATIVE)
    target_compile_options(${target} PRIVATE -march=native)
  endif()
  if(MIMIC_SANITIZE)
    # UBSan stops the test at the first report, so no undefined behaviour passes for a pass.
    target_compile_options(${target} PRIVATE -fsanitize=address,undefined -fno-sanitize-recover=undefined -fno-omit-frame-pointer)
    target_link_options(${target} PRIVATE -fsanitize=address,undefined -fno-sanitize-recover=undefined)
  endif()
endfunction()

function(mimic_add_library name)
  cmake_parse_arguments(ARG "" "" "PUBLIC_DEPS;PRIVATE_DEPS" ${ARGN})
  file(GLOB_RECURSE srcs CONFIGURE_DEPENDS ${CMAKE_CURRENT_SOURCE_DIR}/src/*.cpp)
  add_library(mimic_${name} STATIC ${srcs})
  add_library(mimic::${name} ALIAS mimic_${name})
  target_include_directories(mimic_${name}
    PUBLIC ${CMAKE_CURRENT_SOURCE_DIR}/include
    PRIVATE ${CMAKE_CURRENT_SOURCE_DIR}/src)
  target_link_libraries(mimic_${name} PUBLIC ${ARG_PUBLIC_DEPS} PRIVATE ${ARG_PRIVATE_DEPS})
  target_compile_definitions(mimic_${name} PUBLIC GLM_FORCE_XYZW_ONLY GLM_ENABLE_EXPERIMENTAL)
  mimic_warnings(mimic_${name})
endfunction()

# mimic_add_tests(<lib> DEPS ...): one test binary per library from tests/<lib>/*_test.cpp.
function(mimic_add_tests lib)
  cmake_parse_arguments(ARG "" "" "DEPS" ${ARGN})
  file(GLOB srcs CONFIGURE_DEPENDS ${CMAKE_CURRENT_SOURCE_DIR}/${lib}/*.cpp)
  if(NOT srcs)
    return()
  endif()
  add_executable(mimic_${lib}_tests ${srcs})
  target_link_libraries(mimic_${lib}_tests PRIVATE ${ARG_DEPS} mimic_test_support GTest::gtest_main GTest::gmock)
  # GoogleTest, JSON and the standard headers every test file includes, parsed once per test
  # program instead of once per file: the tests are half of the build.
  target_precompile_headers(mimic_${lib}_tests PRIVATE
    <gtest/gtest.h> <nlohmann/json.hpp> <algorithm> <chrono> <cmath> <cstdio> <filesystem> <map>
    <random> <string> <vector>)
  mimic_warnings(mimic_${lib}_tests)
  # Eight test files per translation unit: GoogleTest's and JSON's templates are instantiated
  # once per batch instead of once per file (each file wraps its contents in a namespace named
  # after it, so batched helpers cannot collide).
  set_target_properties(mimic_${lib}_tests PROPERTIES UNITY_BUILD ON UNITY_BUILD_BATCH_SIZE 8)
  gtest_discover_tests(mimic_${lib}_tests
    # One variable only: gtest_discover_tests splits a list here. Tests find the `mimic`
    # program beside their own binary (tests/support/test_data.h).
    PROPERTIES ENVIRONMENT "MIMIC_SHARED_DATA=${MIMIC_SHARED_DATA}"
    DISCOVERY_TIMEOUT 60)
endfunction()

# mimic_forbid_links(<target> <forbidden target>...): fails the configuration when <target>
# links a forbidden library, directly or through any other, so the rooms stay apart (the solver,
# the simulator, the wire code and the client library never pull in the body or the skin).
function(_mimic_collect_links target out)
  set(seen ${${out}})
  get_target_property(direct ${target} LINK_LIBRARIES)
  get_target_property(iface ${target} INTERFACE_LINK_LIBRARIES)
  foreach(dep IN LISTS direct iface)
    if(NOT dep OR dep MATCHES "^\\$<" OR NOT TARGET ${dep})
      continue()
    endif()
    get_target_property(real ${dep} ALIASED_TARGET)
    if(real)
      set(dep ${real})
    endif()
    if(NOT dep IN_LIST seen)
      list(APPEND seen ${dep})
      set(${out} ${seen})
      _mimic_collect_links(${dep} ${out})
      set(seen ${${out}})
    endif()
  endforeach()
  set(${out} ${seen} PARENT_SCOPE)
endfunction()

function(mimic_forbid_links target)
  if(NOT TARGET ${target})
    return()
  endif()
  set(links "")
  _mimic_collect_links(${target} links)
  foreach(forbidden IN LISTS ARGN)
    if(forbidden IN_LIST links)
      message(FATAL_ERROR "${target} links ${forbidden} (directly or through another library): "
                          "docs/structure.md says which rooms may use which")
    endif()
  endforeach()
endfunction()
