# Run by ctest as `cmake -D... -P run_embedding_test.cmake` (see CMakeLists.txt here):
#   1. install the obs build tree OBS_BINARY_DIR into PREFIX (emptied first),
#   2. configure CONSUMER_SOURCE_DIR in CONSUMER_BINARY_DIR with CMAKE_PREFIX_PATH=PREFIX,
#   3. build it, 4. run its programs and require OK_PATTERN in the output of each.
# Every failing step stops the test with the command and its full output.
# Optional: CONFIG (build configuration), GENERATOR, MAKE_PROGRAM, CXX_COMPILER; CXX_FLAGS and
# EXE_LINKER_FLAGS, the flags obs was built with (a sanitizer build's consumers must link the same
# sanitizer runtime, first in the library list); EXECUTABLES, the
# programs to run, comma-separated (default: consumer); OK_PATTERN, the regular expression each
# program's output must match (default: embedding ok).
cmake_minimum_required(VERSION 3.25)

foreach(var OBS_BINARY_DIR PREFIX CONSUMER_SOURCE_DIR CONSUMER_BINARY_DIR)
  if(NOT DEFINED ${var} OR "${${var}}" STREQUAL "")
    message(FATAL_ERROR "run_embedding_test.cmake: -D${var}=... is required")
  endif()
endforeach()

# fail(<summary> <output>): prints the captured output verbatim (FATAL_ERROR would re-wrap it),
# then stops with the summary.
function(fail summary output)
  message("---- output ----\n${output}\n---- end of output ----")
  message(FATAL_ERROR "embedding test: ${summary}")
endfunction()

# run(<step> <command>...): runs the command; on a non-zero exit fails with its full output.
# The combined stdout/stderr is left in `step_output`.
function(run step)
  string(JOIN " " pretty ${ARGN})
  message(STATUS "[${step}] ${pretty}")
  execute_process(COMMAND ${ARGN}
    RESULT_VARIABLE result
    OUTPUT_VARIABLE output
    ERROR_VARIABLE output)
  if(NOT result STREQUAL "0")
    fail("step '${step}' failed (exit status: ${result}): ${pretty}" "${output}")
  endif()
  set(step_output "${output}" PARENT_SCOPE)
endfunction()

set(config_args "")
set(build_type_args "")
if(NOT "${CONFIG}" STREQUAL "")
  set(config_args --config "${CONFIG}")
  set(build_type_args "-DCMAKE_BUILD_TYPE=${CONFIG}")
endif()
set(generator_args "")
if(NOT "${GENERATOR}" STREQUAL "")
  list(APPEND generator_args -G "${GENERATOR}")
  if(NOT "${MAKE_PROGRAM}" STREQUAL "")
    list(APPEND generator_args "-DCMAKE_MAKE_PROGRAM=${MAKE_PROGRAM}")
  endif()
endif()
set(compiler_args "")
if(NOT "${CXX_COMPILER}" STREQUAL "")
  list(APPEND compiler_args "-DCMAKE_CXX_COMPILER=${CXX_COMPILER}")
endif()
if(NOT "${CXX_FLAGS}" STREQUAL "")
  list(APPEND compiler_args "-DCMAKE_CXX_FLAGS=${CXX_FLAGS}")
endif()
if(NOT "${EXE_LINKER_FLAGS}" STREQUAL "")
  list(APPEND compiler_args "-DCMAKE_EXE_LINKER_FLAGS=${EXE_LINKER_FLAGS}")
endif()

# Start from nothing so that stale files of an earlier run cannot hide a packaging error.
file(REMOVE_RECURSE "${PREFIX}" "${CONSUMER_BINARY_DIR}")

# 1. install
run(install "${CMAKE_COMMAND}" --install "${OBS_BINARY_DIR}" --prefix "${PREFIX}" ${config_args})
file(GLOB_RECURSE config_files "${PREFIX}/*/obsConfig.cmake")
if(NOT config_files)
  fail("no obsConfig.cmake installed under ${PREFIX}" "${step_output}")
endif()

# 2. configure; only the prefix may provide obs (no user or system package registry).
run(configure "${CMAKE_COMMAND}" -S "${CONSUMER_SOURCE_DIR}" -B "${CONSUMER_BINARY_DIR}"
  ${generator_args} ${compiler_args} ${build_type_args}
  "-DCMAKE_PREFIX_PATH=${PREFIX}"
  -DCMAKE_FIND_USE_PACKAGE_REGISTRY=OFF
  -DCMAKE_FIND_USE_SYSTEM_PACKAGE_REGISTRY=OFF)
file(STRINGS "${CONSUMER_BINARY_DIR}/CMakeCache.txt" obs_dir_line REGEX "^obs_DIR:")
string(REGEX REPLACE "^obs_DIR:[A-Z]+=" "" obs_dir "${obs_dir_line}")
file(REAL_PATH "${PREFIX}" real_prefix)
if(EXISTS "${obs_dir}")
  file(REAL_PATH "${obs_dir}" obs_dir)
endif()
string(FIND "${obs_dir}/" "${real_prefix}/" at)
if(NOT at EQUAL 0)
  fail("the consumer found obs in '${obs_dir}', not in ${PREFIX}" "${step_output}")
endif()

# 3. build
run(build "${CMAKE_COMMAND}" --build "${CONSUMER_BINARY_DIR}" ${config_args})

# 4. run every program (the first one is also checked with ldd below)
if(NOT DEFINED EXECUTABLES OR "${EXECUTABLES}" STREQUAL "")
  set(EXECUTABLES consumer)
endif()
if(NOT DEFINED OK_PATTERN OR "${OK_PATTERN}" STREQUAL "")
  set(OK_PATTERN "embedding ok")
endif()
string(REPLACE "," ";" programs "${EXECUTABLES}")
set(exe "")
foreach(program IN LISTS programs)
  set(path "${CONSUMER_BINARY_DIR}/${program}")
  if(NOT EXISTS "${path}" AND NOT "${CONFIG}" STREQUAL "")
    set(path "${CONSUMER_BINARY_DIR}/${CONFIG}/${program}")  # multi-configuration generators
  endif()
  if(exe STREQUAL "")
    set(exe "${path}")
  endif()
  run("run ${program}" "${path}")
  message("${step_output}")
  if(NOT step_output MATCHES "${OK_PATTERN}")
    fail("${program} ran but did not print '${OK_PATTERN}'" "${step_output}")
  endif()
endforeach()

# The obs libraries the consumer loads must be the installed ones, not the build tree's.
find_program(LDD ldd)
if(LDD)
  run(ldd "${LDD}" "${exe}")
  string(REGEX MATCHALL "libobs_[a-z]+[^ \t\n]* => [^ \t\n]+" loaded "${step_output}")
  file(GLOB shared_libs "${PREFIX}/lib*/libobs_*.so*")
  if(shared_libs AND NOT loaded)
    fail("ldd shows no obs library although shared ones are installed" "${step_output}")
  endif()
  foreach(entry IN LISTS loaded)
    string(REGEX REPLACE "^.* => " "" path "${entry}")
    if(path STREQUAL "not")
      fail("${entry} not found" "${step_output}")
    endif()
    file(REAL_PATH "${path}" real_path)
    string(FIND "${real_path}" "${real_prefix}/" at)
    if(NOT at EQUAL 0)
      fail("the consumer loads ${real_path}, not a library installed in ${PREFIX}" "${step_output}")
    endif()
    message(STATUS "[ldd] ${entry}")
  endforeach()
endif()
message(STATUS "embedding test passed")
