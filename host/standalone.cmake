# The flags of a standalone host build (the native replay that hpddo train builds for
# every model, the observers of hpddo compare): the flags the model's golden figures were
# measured with: -O2, no FMA contraction (see the root CMakeLists.txt), assertions off.
# No -Werror: a newer compiler's new warning must not stop a user's run (the root build
# keeps -Werror). Included by host/CMakeLists.txt and host/compare/CMakeLists.txt.
set(CMAKE_CXX_STANDARD_REQUIRED ON)
set(CMAKE_CXX_EXTENSIONS OFF)
if(NOT CMAKE_BUILD_TYPE)
  set(CMAKE_BUILD_TYPE Release CACHE STRING "" FORCE)
endif()
set(CMAKE_CXX_FLAGS_RELEASE "-O2 -DNDEBUG")
add_compile_options(-ffp-contract=off)
set(HPDDO_HOST_WARNINGS -Wall -Wextra)
