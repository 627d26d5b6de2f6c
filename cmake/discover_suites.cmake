# Run at build time (cmake -P, after a test binary links): the ctest tests of TEST_EXE's GoogleTest
# tests, written to OUT for ctest to include (tests/CMakeLists.txt, volcast_discover_suites).
#
# PER_SUITE: one ctest test per suite (but those in PER_TEST_SUITES), named after it and run in one
# process (`--gtest_filter=Suite.*`): its tests share the process's start-up (the dynamic loader,
# the sanitizers, the libraries' static initialisers: 0.3-0.8 CPU seconds for a binary that links
# every library). Otherwise one ctest test per test, named Suite.Test, in a process of its own. A test
# named ALONE runs as a ctest test of its own, RUN_SERIAL; a DISABLED_ test is listed as a disabled
# ctest test, as gtest_discover_tests lists it. A ctest test whose every test skipped is skipped
# (the skip expression names its test count, so one where any test ran is not).
#
# A ctest test's TIMEOUT is 600 s and 60 s more per test after its first: it only bounds a broken
# run.
#
# Inputs (-D): TEST_EXE, OUT, WORKDIR, LABEL; optional PER_SUITE (ON/OFF), PER_TEST_SUITES (suite
# names separated by commas: one ctest test per test even so), COST (seconds per test:
# a suite's COST is that times its tests), LOCK (a RESOURCE_LOCK), ENVIRONMENT (one NAME=VALUE, no
# ';'), ALONE (a full test name).
execute_process(COMMAND "${TEST_EXE}" --gtest_list_tests WORKING_DIRECTORY "${WORKDIR}"
                RESULT_VARIABLE result OUTPUT_VARIABLE listing ERROR_VARIABLE errors TIMEOUT 60)
if(NOT result EQUAL 0)
  message(FATAL_ERROR "${TEST_EXE} --gtest_list_tests failed (${result}): ${errors}")
endif()
# Parameters are named after '#' ("  Test/0  # GetParam() = ..."): dropped before the lines become
# a list (a '[' or ';' in them would split it).
string(REGEX REPLACE "#[^\n]*" "" listing "${listing}")
string(REGEX REPLACE "[][;]" "" listing "${listing}")
string(REPLACE "\n" ";" lines "${listing}")

set(suites "")
set(tests "")
set(disabled "")
set(alone_found FALSE)
foreach(line IN LISTS lines)
  if(line MATCHES "^([^ ]+)\\.[ ]*$")
    set(suite "${CMAKE_MATCH_1}")
  elseif(line MATCHES "^  ([^ ]+)")
    set(name "${suite}.${CMAKE_MATCH_1}")
    if(name MATCHES "(^|\\.|/)DISABLED_")
      list(APPEND disabled "${name}")
    elseif(ALONE AND name STREQUAL ALONE)
      set(alone_found TRUE)
    else()
      list(APPEND tests "${name}")
      if(NOT DEFINED count_${suite})
        list(APPEND suites "${suite}")
        set(count_${suite} 0)
      endif()
      math(EXPR count_${suite} "${count_${suite}} + 1")
    endif()
  endif()
endforeach()
if(ALONE AND NOT alone_found)
  message(FATAL_ERROR "${TEST_EXE}: ALONE names ${ALONE}, which is not one of its tests")
endif()

set(common WORKING_DIRECTORY "${WORKDIR}" LABELS "${LABEL}")
if(LOCK)
  list(APPEND common RESOURCE_LOCK "${LOCK}")
endif()
if(ENVIRONMENT)
  list(APPEND common ENVIRONMENT "${ENVIRONMENT}")
endif()

set(script "")
function(add_one name filter n extra)
  math(EXPR timeout "600 + 60 * (${n} - 1)")
  set(properties ${common} TIMEOUT ${timeout} ${extra})
  if(COST)
    math(EXPR cost "${COST} * ${n}")
    list(APPEND properties COST ${cost})
  endif()
  if(n EQUAL 1)
    set(skipped "\\[  SKIPPED \\] 1 test, listed below")
  else()
    set(skipped "\\[  SKIPPED \\] ${n} tests, listed below")
  endif()
  list(APPEND properties SKIP_REGULAR_EXPRESSION "${skipped}")
  set(quoted "")
  foreach(p IN LISTS properties)
    string(APPEND quoted " [==[${p}]==]")
  endforeach()
  string(APPEND script "add_test([=[${name}]=] [==[${TEST_EXE}]==] [==[--gtest_filter=${filter}]==])\n"
                       "set_tests_properties([=[${name}]=] PROPERTIES${quoted})\n")
  set(script "${script}" PARENT_SCOPE)
endfunction()

string(REPLACE "," ";" per_test_suites "${PER_TEST_SUITES}")
foreach(suite IN LISTS per_test_suites)
  if(NOT DEFINED count_${suite})
    message(FATAL_ERROR "${TEST_EXE}: PER_TEST_SUITES names ${suite}, which is not one of its suites")
  endif()
endforeach()
if(PER_SUITE)
  foreach(name IN LISTS tests)
    string(REGEX REPLACE "\\..*" "" suite "${name}")
    list(FIND per_test_suites "${suite}" at)
    if(at GREATER -1)
      add_one("${name}" "${name}" 1 "")
    endif()
  endforeach()
  foreach(suite IN LISTS suites)
    list(FIND per_test_suites "${suite}" at)
    if(at GREATER -1)
      continue()
    endif()
    set(filter "${suite}.*")
    if(ALONE AND ALONE MATCHES "^${suite}\\.")
      string(APPEND filter ":-${ALONE}")
    endif()
    add_one("${suite}" "${filter}" "${count_${suite}}" "")
  endforeach()
else()
  foreach(name IN LISTS tests)
    add_one("${name}" "${name}" 1 "")
  endforeach()
endif()
if(ALONE)
  add_one("${ALONE}" "${ALONE}" 1 "RUN_SERIAL;TRUE")
endif()
foreach(name IN LISTS disabled)
  string(APPEND script
         "add_test([=[${name}]=] [==[${TEST_EXE}]==] [==[--gtest_filter=${name}]==] --gtest_also_run_disabled_tests)\n"
         "set_tests_properties([=[${name}]=] PROPERTIES DISABLED TRUE LABELS [==[${LABEL}]==])\n")
endforeach()
file(WRITE "${OUT}" "${script}")
