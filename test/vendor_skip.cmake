# Run by the tests registered with hpddo_vendor_skip (test/vendor.cmake): skipped with the
# reason, or, under CI=true, failed with it.
if("$ENV{CI}" STREQUAL "true")
  message(FATAL_ERROR "CI=true and a vendored dependency is missing, which fails in CI: ${REASON}")
endif()
message("hpddo-vendor-skip: ${REASON}")
