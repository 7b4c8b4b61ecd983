# Registers a GoogleTest executable with CTest as one test per suite (run after the executable is
# built, like CMake's gtest_discover_tests, which registers one test per case).
#
#   cmake -D TEST_EXECUTABLE=... -D TEST_NAME=... -D CTEST_FILE=... -D CASE_TIMEOUT=<s>
#         [-D LABELS=label] [-D COSTS=Suite=s,Suite=s] -P gtest_suites.cmake
#
# Each suite runs in one process (`--gtest_filter=Suite.*`), so a suite that builds its scene once
# (SetUpTestSuite: the torso phantom, the shared CT) builds it once, not once per case. The test is
# named TEST_NAME:Suite (a suite name may recur in two executables); its timeout is CASE_TIMEOUT
# per case. Exit code 77 (tests/support/gtest_main.cpp: every case of the run skipped) is a skip.
cmake_minimum_required(VERSION 3.25)

foreach(required TEST_EXECUTABLE TEST_NAME CTEST_FILE CASE_TIMEOUT)
  if(NOT DEFINED ${required})
    message(FATAL_ERROR "gtest_suites.cmake: ${required} not set")
  endif()
endforeach()

execute_process(COMMAND "${TEST_EXECUTABLE}" --gtest_list_tests
                OUTPUT_VARIABLE listing RESULT_VARIABLE result TIMEOUT 60)
if(NOT result EQUAL 0)
  message(FATAL_ERROR "${TEST_EXECUTABLE} --gtest_list_tests failed (${result}):\n${listing}")
endif()

# The listing: a suite per unindented line ("Suite." or "Prefix/Suite.  # TypeParam = ..."), its
# cases indented below it.
string(REPLACE ";" "\\;" listing "${listing}")
string(REPLACE "\n" ";" lines "${listing}")
set(suites "")
set(suite "")
foreach(line IN LISTS lines)
  if(line MATCHES "^([A-Za-z0-9_/]+)\\.")
    set(suite "${CMAKE_MATCH_1}")
    list(APPEND suites "${suite}")
    set(cases_${suite} 0)
  elseif(line MATCHES "^  [A-Za-z0-9_/]" AND NOT suite STREQUAL "")
    math(EXPR cases_${suite} "${cases_${suite}} + 1")
  endif()
endforeach()
if(suites STREQUAL "")
  message(FATAL_ERROR "${TEST_EXECUTABLE}: no test suites listed")
endif()

# COSTS: Suite=seconds for the long suites (CTest starts the costliest first).
string(REPLACE "," ";" costs "${COSTS}")
foreach(entry IN LISTS costs)
  if(entry MATCHES "^([A-Za-z0-9_/]+)=([0-9.]+)$")
    set(cost_${CMAKE_MATCH_1} ${CMAKE_MATCH_2})
  elseif(NOT entry STREQUAL "")
    message(FATAL_ERROR "gtest_suites.cmake: COSTS entry '${entry}' is not Suite=seconds")
  endif()
endforeach()

set(script "")
foreach(suite IN LISTS suites)
  if(suite MATCHES "^DISABLED_" OR suite MATCHES "/DISABLED_")
    continue()
  endif()
  math(EXPR timeout "${CASE_TIMEOUT} * ${cases_${suite}}")
  set(name "${TEST_NAME}:${suite}")
  string(APPEND script
    "add_test([==[${name}]==] [==[${TEST_EXECUTABLE}]==] [==[--gtest_filter=${suite}.*]==])\n"
    "set_tests_properties([==[${name}]==] PROPERTIES TIMEOUT ${timeout} SKIP_RETURN_CODE 77")
  if(LABELS)
    string(APPEND script " LABELS [==[${LABELS}]==]")
  endif()
  if(DEFINED cost_${suite})
    string(APPEND script " COST ${cost_${suite}}")
  endif()
  string(APPEND script ")\n")
endforeach()
file(WRITE "${CTEST_FILE}" "${script}")
