# Third-party sources the tests build against but the project does not copy: ArduinoJson,
# Unity and the ESP8266 Arduino core, kept unmodified beside the repository in
# ../shared/vendor (its README gives versions and licences; users get the same versions
# from PlatformIO). Where a copy is absent, each test that needs it is registered anyway
# and reports itself skipped with the reason; with CI=true in the environment of ctest
# the same test fails instead, so that CI never passes without them.
set(HPDDO_VENDOR_DIR "${CMAKE_SOURCE_DIR}/../shared/vendor" CACHE PATH
    "Folder holding ArduinoJson-7.2.0, Unity-2.6.1 and esp8266-arduino (../shared/vendor)")
get_filename_component(HPDDO_VENDOR_DIR_ABS "${HPDDO_VENDOR_DIR}" ABSOLUTE)
set(HPDDO_UNITY_SRC ${HPDDO_VENDOR_DIR_ABS}/Unity-2.6.1/src)
set(HPDDO_ARDUINOJSON_SRC ${HPDDO_VENDOR_DIR_ABS}/ArduinoJson-7.2.0/src)
set(HPDDO_ESP8266_CORE ${HPDDO_VENDOR_DIR_ABS}/esp8266-arduino)
set(HPDDO_NEWLIB_SHIMS ${HPDDO_VENDOR_DIR_ABS}/newlib-xtensa-shims)

# hpddo_vendor_present(<var> <file>...): <var> is TRUE when every file exists.
function(hpddo_vendor_present var)
  set(ok TRUE)
  foreach(f ${ARGN})
    if(NOT EXISTS ${f})
      set(ok FALSE)
    endif()
  endforeach()
  set(${var} ${ok} PARENT_SCOPE)
endfunction()

# hpddo_vendor_skip(<test name> <reason>): a test that says why it cannot run; skipped,
# or failed under CI=true.
function(hpddo_vendor_skip name reason)
  message(STATUS "${name}: skipped at test time: ${reason}")
  add_test(NAME ${name} COMMAND ${CMAKE_COMMAND} "-DREASON=${reason}" -P ${CMAKE_SOURCE_DIR}/test/vendor_skip.cmake)
  set_tests_properties(${name} PROPERTIES SKIP_REGULAR_EXPRESSION "hpddo-vendor-skip:")
endfunction()
