# kiln_add_shader_pack(<target> PACK <pack.json> [SCENES <scene.json>...] [TARGETS spirv glsl gles msl]
#                      [OUTPUT_DIR <dir>] [CACHE_DIR <dir>])
#
# Adds a custom target <target> (built by ALL) whose output is the variant pack of <pack.json>. kiln writes
# a depfile listing every HLSL file it read, so editing any included file rebuilds the pack (and nothing
# else), and a build with no change does no work, with Ninja and with Unix Makefiles.
#
# Target properties set on <target> for consumers:
#   KILN_PACK_DIR       directory holding the pack
#   KILN_PACK_MANIFEST  <dir>/<name>.manifest.json
#   KILN_PACK_ARCHIVE   <dir>/<name>.kpack
# Install the pack with: install(DIRECTORY $<TARGET_PROPERTY:<target>,KILN_PACK_DIR>/ DESTINATION ...)
# or kiln_install_shader_pack(<target> DESTINATION <dir>).
include_guard(GLOBAL)

function(kiln_add_shader_pack target)
  cmake_parse_arguments(PARSE_ARGV 1 ARG "" "PACK;OUTPUT_DIR;CACHE_DIR" "SCENES;TARGETS")
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

  set(manifest "${output_dir}/${pack_name}.manifest.json")
  set(archive "${output_dir}/${pack_name}.kpack")
  set(depfile "${output_dir}/${pack_name}.d")
  add_custom_command(
    OUTPUT "${manifest}" "${archive}"
    COMMAND kiln::kiln build "${pack}" -o "${output_dir}" --cache "${cache_dir}" --depfile "${depfile}"
            ${scene_args} ${target_args} -q
    DEPENDS "${pack}" ${scene_files} kiln::kiln
    DEPFILE "${depfile}"
    COMMENT "kiln: building shader pack '${pack_name}'"
    VERBATIM)
  add_custom_target(${target} ALL DEPENDS "${manifest}" "${archive}")
  set_target_properties(${target} PROPERTIES
    KILN_PACK_DIR "${output_dir}"
    KILN_PACK_MANIFEST "${manifest}"
    KILN_PACK_ARCHIVE "${archive}")
endfunction()

# kiln_install_shader_pack(<target> DESTINATION <dir>): installs the pack's manifest and archive.
function(kiln_install_shader_pack target)
  cmake_parse_arguments(PARSE_ARGV 1 ARG "" "DESTINATION" "")
  get_target_property(manifest ${target} KILN_PACK_MANIFEST)
  get_target_property(archive ${target} KILN_PACK_ARCHIVE)
  install(FILES "${manifest}" "${archive}" DESTINATION "${ARG_DESTINATION}")
endfunction()
