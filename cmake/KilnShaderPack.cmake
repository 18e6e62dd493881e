# SPDX-License-Identifier: Apache-2.0
# kiln_add_shader_pack(<target> PACK <pack.json> [NAME <pack name>] [SCENES <scene.json>...]
#                      [TARGETS spirv glsl gles msl] [OUTPUT_DIR <dir>] [CACHE_DIR <dir>]
#                      [DEFINES NAME[=VALUE]...] [OPTIONS <kiln build argument>...] [DEPENDS <file or target>...] [EXCLUDE_FROM_ALL]
#                      [USAGE <usage log>...]
#                      [REMOTE <url>] [REMOTE_UPLOAD])
#
# Adds a custom target <target> (built by ALL unless EXCLUDE_FROM_ALL) whose output is the variant pack of
# <pack.json>, and <target>_watch, never built by ALL, which runs `kiln watch` on the same inputs into the same
# directory until Ctrl-C (docs/development-loop.md; OPTIONS reach it too, so give only options kiln watch takes
# there, the remote cache's aside). kiln writes a depfile listing every HLSL file it read, so editing any included
# file rebuilds the pack (and nothing else), and a build with no change does no work, with Ninja and with Unix
# Makefiles.
#   OPTIONS   extra arguments for `kiln build` (e.g. --frontend glslang, --worker-timeout 300, -j 4)
#   DEFINES   passed as `kiln build -D` (they win over the pack definition's "defines"; docs/bindings.md);
#             changing them rebuilds
#   DEPENDS   more files or targets the pack's build depends on (e.g. a target that generates an HLSL file)
#   USAGE     usage logs recorded by the game's readers: keep only the variants they asked for (docs/usage.md;
#             `kiln build --usage`; pass --usage-tag / --usage-margin through OPTIONS)
# Paths may be relative (to the current source directory; OUTPUT_DIR to the current binary directory) and may
# hold generator expressions (`$<CONFIG>`, `$<TARGET_PROPERTY:...>`). A file named without one is checked now:
# a missing pack or scene file is a configure error. With one, it is known only at build time, where the build tool
# (or kiln) reports a missing file; a PACK with a generator expression needs NAME (the pack's "name", which decides the
# output's file names).
#
# The kiln that runs is the host tool: the KILN_EXECUTABLE cache variable when it is set, and it must be set
# when CMAKE_CROSSCOMPILING (the imported kiln::kiln of a cross sysroot is built for the target); otherwise
# kiln::kiln (the add_subdirectory'd or find_package'd kiln).
#
# REMOTE names a shared remote cache (docs/remote-cache.md; KILN_REMOTE in the environment does the same);
# REMOTE_UPLOAD lets this build write to it. Tokens come from the environment, never from the build files.
#
# Target properties set on <target> for consumers:
#   KILN_PACK_DIR       directory holding the pack
#   KILN_PACK_MANIFEST  <dir>/<name>.manifest.json
# The archive beside the manifest is named by its content (<name>.<XXH3-64>.kpack, see kiln/pack_format.hpp),
# so its name is known only once the pack is built: the manifest names it, and the custom command lists only
# the manifest as its output. Install the pack with kiln_install_shader_pack(<target> DESTINATION <dir>),
# which installs the manifest and the archive it names (installing the directory would also copy kiln's stamp
# and depfile, and an archive a killed build orphaned).
include_guard(GLOBAL)

set(KILN_EXECUTABLE "" CACHE FILEPATH "kiln to run at build time (the host tool; required when cross-compiling)")

# `path` made absolute against `base`: now when it is a plain path, at generate time when it holds a genex.
function(_kiln_absolute_path out path base)
  if(path MATCHES "\\$<")
    set(${out} "$<PATH:ABSOLUTE_PATH,NORMALIZE,${path},${base}>" PARENT_SCOPE)
  else()
    get_filename_component(path "${path}" ABSOLUTE BASE_DIR "${base}")
    set(${out} "${path}" PARENT_SCOPE)
  endif()
endfunction()

function(_kiln_host_executable out)
  if(KILN_EXECUTABLE)
    if(NOT KILN_EXECUTABLE MATCHES "\\$<" AND NOT EXISTS "${KILN_EXECUTABLE}")
      message(FATAL_ERROR "kiln_add_shader_pack: KILN_EXECUTABLE is '${KILN_EXECUTABLE}', which does not exist")
    endif()
    set(${out} "${KILN_EXECUTABLE}" PARENT_SCOPE)
  elseif(CMAKE_CROSSCOMPILING)
    message(FATAL_ERROR "kiln_add_shader_pack: cross-compiling (CMAKE_SYSTEM_NAME ${CMAKE_SYSTEM_NAME}): set the "
                        "KILN_EXECUTABLE cache variable to a kiln that runs on this machine, e.g. "
                        "-DKILN_EXECUTABLE=/usr/bin/kiln (the kiln::kiln found for the target cannot run here)")
  elseif(TARGET kiln::kiln)
    set(${out} kiln::kiln PARENT_SCOPE)
  else()
    message(FATAL_ERROR "kiln_add_shader_pack: no kiln: find_package(kiln) or add_subdirectory(kiln) first, "
                        "or set KILN_EXECUTABLE")
  endif()
endfunction()

function(kiln_add_shader_pack target)
  cmake_parse_arguments(PARSE_ARGV 1 ARG "EXCLUDE_FROM_ALL;REMOTE_UPLOAD" "PACK;NAME;OUTPUT_DIR;CACHE_DIR;REMOTE" "SCENES;TARGETS;DEFINES;OPTIONS;DEPENDS;USAGE")
  if(NOT ARG_PACK)
    message(FATAL_ERROR "kiln_add_shader_pack(${target}): PACK <pack.json> is required")
  endif()
  if(ARG_UNPARSED_ARGUMENTS)
    message(FATAL_ERROR "kiln_add_shader_pack(${target}): unknown arguments ${ARG_UNPARSED_ARGUMENTS}")
  endif()
  _kiln_host_executable(kiln)
  _kiln_absolute_path(pack "${ARG_PACK}" "${CMAKE_CURRENT_SOURCE_DIR}")
  if(ARG_PACK MATCHES "\\$<")
    if(NOT ARG_NAME)
      message(FATAL_ERROR "kiln_add_shader_pack(${target}): PACK '${ARG_PACK}' holds a generator expression: "
                          "give the pack's name with NAME <name> (it decides the output's file names)")
    endif()
    set(pack_name "${ARG_NAME}")
  else()
    if(NOT EXISTS "${pack}" OR IS_DIRECTORY "${pack}")
      message(FATAL_ERROR "kiln_add_shader_pack(${target}): pack definition '${pack}' does not exist (PACK ${ARG_PACK})")
    endif()
    # The pack's name decides its file names; read it at configure time (and reconfigure if it changes).
    file(READ "${pack}" pack_json)
    string(JSON pack_name ERROR_VARIABLE json_error GET "${pack_json}" name)
    if(json_error)
      message(FATAL_ERROR "kiln_add_shader_pack(${target}): ${pack}: ${json_error}")
    endif()
    if(ARG_NAME AND NOT ARG_NAME STREQUAL pack_name)
      message(FATAL_ERROR "kiln_add_shader_pack(${target}): NAME ${ARG_NAME} but ${pack} names the pack '${pack_name}'")
    endif()
    set_property(DIRECTORY APPEND PROPERTY CMAKE_CONFIGURE_DEPENDS "${pack}")
  endif()

  set(output_dir "${ARG_OUTPUT_DIR}")
  if(NOT output_dir)
    set(output_dir "${CMAKE_CURRENT_BINARY_DIR}/${target}")
  endif()
  _kiln_absolute_path(output_dir "${output_dir}" "${CMAKE_CURRENT_BINARY_DIR}")
  set(cache_dir "${ARG_CACHE_DIR}")
  if(NOT cache_dir)
    set(cache_dir "${CMAKE_BINARY_DIR}/kiln-cache")
  endif()
  _kiln_absolute_path(cache_dir "${cache_dir}" "${CMAKE_CURRENT_BINARY_DIR}")

  set(scene_args "")
  set(scene_files "")
  foreach(scene IN LISTS ARG_SCENES)
    _kiln_absolute_path(absolute "${scene}" "${CMAKE_CURRENT_SOURCE_DIR}")
    if(scene MATCHES "\\$<")
      # Empty when the expression is (for this configuration): then no --scene at all.
      list(APPEND scene_args "$<$<BOOL:${scene}>:--scene$<SEMICOLON>${absolute}>")
      list(APPEND scene_files "$<$<BOOL:${scene}>:${absolute}>")
    else()
      if(NOT EXISTS "${absolute}" OR IS_DIRECTORY "${absolute}")
        message(FATAL_ERROR "kiln_add_shader_pack(${target}): scene profile '${absolute}' does not exist (SCENES ${scene})")
      endif()
      list(APPEND scene_args --scene "${absolute}")
      list(APPEND scene_files "${absolute}")
    endif()
  endforeach()
  set(target_args "")
  if(ARG_TARGETS)
    string(REPLACE ";" "," target_list "${ARG_TARGETS}")
    set(target_args --targets "${target_list}")
  endif()
  set(all ALL)
  if(ARG_EXCLUDE_FROM_ALL)
    set(all "")
  endif()

  set(define_args "")
  foreach(define IN LISTS ARG_DEFINES)
    list(APPEND define_args -D "${define}")
  endforeach()

  set(remote_args "")
  if(ARG_REMOTE)
    list(APPEND remote_args --remote "${ARG_REMOTE}")
  endif()
  if(ARG_REMOTE_UPLOAD)
    list(APPEND remote_args --remote-upload)
  endif()

  # Usage logs (docs/usage.md): the variants recorded runs asked for; a changed log rebuilds the pack.
  set(usage_args "")
  set(usage_files "")
  foreach(log IN LISTS ARG_USAGE)
    get_filename_component(absolute "${log}" ABSOLUTE BASE_DIR "${CMAKE_CURRENT_SOURCE_DIR}")
    list(APPEND usage_args --usage "${absolute}")
    list(APPEND usage_files "${absolute}")
  endforeach()

  set(manifest "${output_dir}/${pack_name}.manifest.json")
  set(depfile "${output_dir}/${pack_name}.d")
  add_custom_command(
    OUTPUT "${manifest}"
    COMMAND "${kiln}" build "${pack}" -o "${output_dir}" --cache "${cache_dir}" --depfile "${depfile}"
            ${scene_args} ${usage_args} ${target_args} ${define_args} ${remote_args} ${ARG_OPTIONS} -q
    DEPENDS "${pack}" ${scene_files} ${usage_files} "${kiln}" ${ARG_DEPENDS}
    DEPFILE "${depfile}"
    COMMENT "kiln: building shader pack '${pack_name}'"
    COMMAND_EXPAND_LISTS
    VERBATIM)
  add_custom_target(${target} ${all} DEPENDS "${manifest}")
  # The development loop (docs/development-loop.md): `cmake --build . --target <target>_watch` runs kiln watch on the
  # same inputs into the same directory until Ctrl-C, rebuilding on each edit (the USAGE logs' variants first). Never
  # part of ALL: it does not end. The terminal is its own (USES_TERMINAL: Ninja's console pool), for its status lines
  # and Ctrl-C.
  add_custom_target(${target}_watch
    COMMAND "${kiln}" watch "${pack}" -o "${output_dir}" --cache "${cache_dir}"
            ${scene_args} ${usage_args} ${target_args} ${define_args} ${ARG_OPTIONS}
    DEPENDS ${ARG_DEPENDS}
    USES_TERMINAL
    COMMENT "kiln: watching shader pack '${pack_name}' (Ctrl-C ends)"
    COMMAND_EXPAND_LISTS
    VERBATIM)
  set_target_properties(${target} PROPERTIES
    KILN_PACK_DIR "${output_dir}"
    KILN_PACK_NAME "${pack_name}"
    KILN_PACK_MANIFEST "${manifest}")
endfunction()

# kiln_install_shader_pack(<target> DESTINATION <dir>): installs the pack's manifest and the archive it names.
function(kiln_install_shader_pack target)
  cmake_parse_arguments(PARSE_ARGV 1 ARG "" "DESTINATION" "")
  if(NOT ARG_DESTINATION)
    message(FATAL_ERROR "kiln_install_shader_pack(${target}): DESTINATION <dir> is required")
  endif()
  if(NOT TARGET ${target})
    message(FATAL_ERROR "kiln_install_shader_pack(${target}): no target named '${target}' (make it with kiln_add_shader_pack first)")
  endif()
  get_target_property(manifest ${target} KILN_PACK_MANIFEST)
  get_target_property(pack_name ${target} KILN_PACK_NAME)
  if(NOT manifest OR NOT pack_name)
    message(FATAL_ERROR "kiln_install_shader_pack(${target}): '${target}' is not a shader pack: only a target made "
                        "by kiln_add_shader_pack can be installed this way")
  endif()
  # Which archive the manifest names is known at install time, not now: the install script reads it then.
  install(CODE "include(\"${CMAKE_CURRENT_FUNCTION_LIST_FILE}\")
_kiln_install_pack_files(\"${manifest}\" \"${pack_name}\" \"${ARG_DESTINATION}\")")
endfunction()

# Runs in the install script: the archive first, then the manifest that names it.
function(_kiln_install_pack_files manifest pack_name destination)
  file(READ "${manifest}" text)
  string(JSON archive ERROR_VARIABLE json_error GET "${text}" archive file)
  string(REPEAT "[0-9a-f]" 16 hex_digits)
  string(REPLACE "." "\\." name_pattern "${pack_name}")
  if(json_error OR NOT archive MATCHES "^${name_pattern}\\.${hex_digits}\\.kpack$")
    message(FATAL_ERROR "kiln_install_shader_pack: ${manifest} does not name an archive of pack '${pack_name}'")
  endif()
  if(NOT IS_ABSOLUTE "${destination}")
    set(destination "${CMAKE_INSTALL_PREFIX}/${destination}")
  endif()
  get_filename_component(directory "${manifest}" DIRECTORY)
  file(INSTALL "${directory}/${archive}" DESTINATION "${destination}")
  file(INSTALL "${manifest}" DESTINATION "${destination}")
endfunction()
