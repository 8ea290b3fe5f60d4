# impostor_process_suite: one GoogleTest binary whose tests start real
# impostor-server / impostor-worker / impostor processes through the shared
# harness (tests/support, impostor_test_support). What every such suite
# repeated is here once: the harness and the gRPC, API and GoogleTest
# libraries linked, where the binaries and the assets are
# (IMPOSTOR_TEST_BINARY_DIR, IMPOSTOR_TEST_ASSETS_DIR), the binaries built
# first, and the tests discovered with their label.
#
#   impostor_process_suite(NAME
#     SOURCES a_test.cc b_test.cc   the suite's own files
#     [LIBS lib ...]                further libraries
#     [NEEDS impostor-server ...]   targets its tests run (built before it)
#     [LABEL integration]           the CTest label (one: gtest_discover_tests
#                                   splits "a;b", see tests/integration)
#     [WORKERS]                     runs lavapipe workers: holds the
#                                   impostor_workers resource lock, so
#                                   `ctest -j N` runs one such suite at a time
#     [NO_DISCOVER])                the caller registers the tests itself
function(impostor_process_suite name)
  cmake_parse_arguments(PARSE_ARGV 1 S "WORKERS;NO_DISCOVER" "LABEL" "SOURCES;LIBS;NEEDS")
  if(S_UNPARSED_ARGUMENTS)
    message(FATAL_ERROR "impostor_process_suite(${name}): unknown arguments ${S_UNPARSED_ARGUMENTS}")
  endif()
  add_executable(${name} ${S_SOURCES})
  target_link_libraries(${name} PRIVATE impostor_test_support ${S_LIBS} impostor_api impostor_proto gRPC::grpc++
    GTest::gtest_main)
  target_compile_definitions(${name} PRIVATE
    IMPOSTOR_TEST_BINARY_DIR="${CMAKE_BINARY_DIR}/bin"
    IMPOSTOR_TEST_ASSETS_DIR="${IMPOSTOR_ASSETS_DIR}")
  if(S_NEEDS)
    add_dependencies(${name} ${S_NEEDS})
  endif()
  if(S_NO_DISCOVER)
    return()
  endif()
  if(NOT S_LABEL)
    set(S_LABEL integration)
  endif()
  if(S_WORKERS)
    gtest_discover_tests(${name} PROPERTIES LABELS ${S_LABEL} RESOURCE_LOCK impostor_workers DISCOVERY_TIMEOUT 60)
  else()
    gtest_discover_tests(${name} PROPERTIES LABELS ${S_LABEL} DISCOVERY_TIMEOUT 60)
  endif()
endfunction()
