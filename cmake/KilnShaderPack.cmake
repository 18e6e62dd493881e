# kiln_add_shader_pack(<target> PACK <pack.json> [SCENES <scene.json>...] [TARGETS spirv glsl gles msl]
#                      [OUTPUT_DIR <dir>] [CACHE_DIR <dir>] [REMOTE <url>] [REMOTE_UPLOAD])
#
# Adds a custom target <target> (built by ALL) whose output is the variant pack of <pack.json>. kiln writes
# a depfile listing every HLSL file it read, so editing any included file rebuilds the pack (and nothing
# else), and a build with no change does no work, with Ninja and with Unix Makefiles.
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

function(kiln_add_shader_pack target)
  cmake_parse_arguments(PARSE_ARGV 1 ARG "REMOTE_UPLOAD" "PACK;OUTPUT_DIR;CACHE_DIR;REMOTE" "SCENES;TARGETS")
  if(NOT ARG_PACK)
    message(FATAL_ERROR "kiln_add_shader_pack(${target}): PACK <pack.json> is required")
  endif()
  if(ARG_UNPARSED_ARGUMENTS)
    message(FATAL_ERROR "kiln_add_shader_pack(${target}): unknown arguments ${ARG_UNPARSED_ARGUMENTS}")
  endif()
  get_filename_component(pack "${ARG_PACK}" ABSOLUTE BASE_DIR "${CMAKE_CURRENT_SOURCE_DIR}")
  # The pack's name decides its file names; read it at configure time (and reconfigure if it changes).
  file(READ "${pack}" pack_json)
  string(JSON pack_name ERROR_VARIABLE json_error GET "${pack_json}" name)
  if(json_error)
    message(FATAL_ERROR "kiln_add_shader_pack(${target}): ${pack}: ${json_error}")
  endif()
  set_property(DIRECTORY APPEND PROPERTY CMAKE_CONFIGURE_DEPENDS "${pack}")

  set(output_dir "${ARG_OUTPUT_DIR}")
  if(NOT output_dir)
    set(output_dir "${CMAKE_CURRENT_BINARY_DIR}/${target}")
  endif()
  get_filename_component(output_dir "${output_dir}" ABSOLUTE BASE_DIR "${CMAKE_CURRENT_BINARY_DIR}")
  set(cache_dir "${ARG_CACHE_DIR}")
  if(NOT cache_dir)
    set(cache_dir "${CMAKE_BINARY_DIR}/kiln-cache")
  endif()

  set(scene_args "")
  set(scene_files "")
  foreach(scene IN LISTS ARG_SCENES)
    get_filename_component(scene "${scene}" ABSOLUTE BASE_DIR "${CMAKE_CURRENT_SOURCE_DIR}")
    list(APPEND scene_args --scene "${scene}")
    list(APPEND scene_files "${scene}")
  endforeach()
  set(target_args "")
  if(ARG_TARGETS)
    string(REPLACE ";" "," target_list "${ARG_TARGETS}")
    set(target_args --targets "${target_list}")
  endif()

  set(remote_args "")
  if(ARG_REMOTE)
    list(APPEND remote_args --remote "${ARG_REMOTE}")
  endif()
  if(ARG_REMOTE_UPLOAD)
    list(APPEND remote_args --remote-upload)
  endif()

  set(manifest "${output_dir}/${pack_name}.manifest.json")
  set(depfile "${output_dir}/${pack_name}.d")
  add_custom_command(
    OUTPUT "${manifest}"
    COMMAND kiln::kiln build "${pack}" -o "${output_dir}" --cache "${cache_dir}" --depfile "${depfile}"
            ${scene_args} ${target_args} ${remote_args} -q
    DEPENDS "${pack}" ${scene_files} kiln::kiln
    DEPFILE "${depfile}"
    COMMENT "kiln: building shader pack '${pack_name}'"
    VERBATIM)
  add_custom_target(${target} ALL DEPENDS "${manifest}")
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
  get_target_property(manifest ${target} KILN_PACK_MANIFEST)
  get_target_property(pack_name ${target} KILN_PACK_NAME)
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
