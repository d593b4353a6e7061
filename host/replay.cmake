# hpddo_replay(target model_dir model_name): the native replay (replay.cpp) built against
# model_dir/model_<model_name>.h. Needs the target hpddo_core and HPDDO_HOST_WARNINGS;
# used by host/CMakeLists.txt in both of its modes.
find_package(Eigen3 3.3 REQUIRED NO_MODULE)
set(HPDDO_REPLAY_SOURCE_DIR ${CMAKE_CURRENT_LIST_DIR})

function(hpddo_replay target model_dir model_name)
  add_executable(${target} ${HPDDO_REPLAY_SOURCE_DIR}/replay.cpp)
  set_target_properties(${target} PROPERTIES CXX_STANDARD 17)
  target_include_directories(${target} PRIVATE ${HPDDO_REPLAY_SOURCE_DIR} ${model_dir})
  target_compile_definitions(${target} PRIVATE HPDDO_MODEL_HEADER="model_${model_name}.h"
                                               HPDDO_MODEL_NS=hpddo_model_${model_name})
  target_link_libraries(${target} PRIVATE hpddo_core Eigen3::Eigen)
  target_compile_options(${target} PRIVATE ${HPDDO_HOST_WARNINGS})
endfunction()
