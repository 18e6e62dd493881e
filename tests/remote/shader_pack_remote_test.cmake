# SPDX-License-Identifier: Apache-2.0
# kiln_add_shader_pack(... REMOTE <url> REMOTE_UPLOAD) puts --remote <url> --remote-upload on kiln's command line,
# and without them neither appears. Configures two tiny projects with Ninja and reads the commands they generate.
# Run: cmake -DKILN_SOURCE_DIR=<kiln> -DWORK=<scratch dir> -P shader_pack_remote_test.cmake
file(REMOVE_RECURSE "${WORK}")
foreach(variant IN ITEMS with without)
  set(src "${WORK}/${variant}")
  file(WRITE "${src}/p.pack.json" [=[{"name": "p", "passes": []}]=])
  if(variant STREQUAL "with")
    set(arguments "REMOTE https://cache.example.com/kiln REMOTE_UPLOAD")
  else()
    set(arguments "")
  endif()
  file(WRITE "${src}/CMakeLists.txt" "cmake_minimum_required(VERSION 3.25)\nproject(consumer NONE)\n"
       "add_executable(kiln::kiln IMPORTED)\nset_target_properties(kiln::kiln PROPERTIES IMPORTED_LOCATION /usr/bin/true)\n"
       "include(\"${KILN_SOURCE_DIR}/cmake/KilnShaderPack.cmake\")\n"
       "kiln_add_shader_pack(shaders PACK p.pack.json ${arguments})\n")
  execute_process(COMMAND ${CMAKE_COMMAND} -S "${src}" -B "${src}/build" -G Ninja RESULT_VARIABLE result OUTPUT_QUIET
                  ERROR_VARIABLE error)
  if(NOT result EQUAL 0)
    message(FATAL_ERROR "configuring the ${variant} project failed: ${error}")
  endif()
  file(READ "${src}/build/build.ninja" ninja)
  string(FIND "${ninja}" "--remote https://cache.example.com/kiln --remote-upload" at)
  if(variant STREQUAL "with" AND at EQUAL -1)
    message(FATAL_ERROR "REMOTE and REMOTE_UPLOAD did not reach kiln's command line")
  endif()
  string(FIND "${ninja}" "--remote" any)
  if(variant STREQUAL "without" AND NOT any EQUAL -1)
    message(FATAL_ERROR "--remote appeared without REMOTE")
  endif()
endforeach()
message(STATUS "REMOTE and REMOTE_UPLOAD reach kiln's command line")
