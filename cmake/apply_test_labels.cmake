# Read by ctest after the GoogleTest tests of ssc_tests are defined (TEST_INCLUDE_FILES, appended after
# gtest_discover_tests in CMakeLists.txt): gives each test its label from cmake/test_labels.cmake.
include("${CMAKE_CURRENT_LIST_DIR}/test_labels.cmake")
foreach(ssc_test IN LISTS ssc_tests_TESTS)
  ssc_test_label("${ssc_test}" ssc_label)
  if(ssc_label STREQUAL "")
    set(ssc_label ${SSC_DEFAULT_TEST_LABEL})
  endif()
  list(APPEND ssc_labelled_${ssc_label} "${ssc_test}")
endforeach()
foreach(ssc_label IN LISTS SSC_TEST_LABELS)
  if(ssc_labelled_${ssc_label})
    set_tests_properties(${ssc_labelled_${ssc_label}} PROPERTIES LABELS ${ssc_label})
  endif()
endforeach()
# A slow test may take longer than ctest's default timeout (tools/run-tests: 600 s) on a slower
# machine: `ssc diagnose` of the CI cube ran past 600 s on a 2-core machine 2.4x slower than the
# one of docs/architecture.md's label table (2026-11-28).
if(ssc_labelled_slow)
  set_tests_properties(${ssc_labelled_slow} PROPERTIES TIMEOUT 1800)
endif()
