# A must-not-compile check (ctest compile.fail.*), run as
#   cmake -DCMD="compiler|flags..." -DSOURCE=file.cpp -P expect_error.cmake
# Passes only when
#   1. SOURCE does not compile,
#   2. the compiler's output contains the text of SOURCE's "// expect: " line (the
#      static_assert's message, so that a typo does not pass as the intended failure),
#   3. SOURCE compiles, warning-free, with -DHPDDO_CONTROL (the same use with a valid
#      size): the failure comes from the misuse, not from the rest of the file.
string(REPLACE "|" ";" cmd "${CMD}")
file(STRINGS ${SOURCE} expect_lines REGEX "^// expect: ")
list(LENGTH expect_lines n)
if(NOT n EQUAL 1)
  message(FATAL_ERROR "${SOURCE}: needs exactly one '// expect: ' line, has ${n}")
endif()
string(REGEX REPLACE "^// expect: " "" expect "${expect_lines}")

execute_process(COMMAND ${cmd} -c -o /dev/null ${SOURCE} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(rc EQUAL 0)
  message(FATAL_ERROR "${SOURCE}: compiled, but must not (expected: ${expect})")
endif()
string(FIND "${out}${err}" "${expect}" at)
if(at EQUAL -1)
  message(FATAL_ERROR "${SOURCE}: failed, but not with '${expect}':\n${out}${err}")
endif()

execute_process(COMMAND ${cmd} -DHPDDO_CONTROL -c -o /dev/null ${SOURCE} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "${SOURCE}: the control (-DHPDDO_CONTROL) does not compile:\n${out}${err}")
endif()
message(STATUS "${SOURCE}: refused with '${expect}'; the control compiles")
