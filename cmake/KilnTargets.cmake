# SPDX-License-Identifier: Apache-2.0
# What the build needs from kiln's output targets, read from their table, compiler/include/kiln/targets.def (one row
# per target; the C++ code is generated from the same rows by the preprocessor). Sets:
#   KILN_TARGET_IDS               every target's id, in row order ("spirv glsl gles msl")
#   KILN_TARGET_EMIT_STAGES       the `--emit` stages, in pipeline order (bash completion)
#   KILN_CROSS_TARGET_SOURCES     each SPIRV-Cross back end's file, src/cross/<id>_target.cpp
#   KILN_SPIRV_CROSS_LIBRARIES    the SPIRV-Cross libraries kiln links and fingerprints: core, the back ends' in row
#                                 order, reflect (the fingerprint's order: it is part of every cache key)
#   KILN_SPIRV_CROSS_LINK_ORDER   the same, each library before those it uses (for static linking)
set(KILN_TARGETS_DEF ${CMAKE_CURRENT_LIST_DIR}/../compiler/include/kiln/targets.def)
set_property(DIRECTORY APPEND PROPERTY CMAKE_CONFIGURE_DEPENDS ${KILN_TARGETS_DEF})
file(READ ${KILN_TARGETS_DEF} kiln_targets_text)
# A row up to its library: KILN_[CROSS_]TARGET(Enumerator, id, "ext", "other exts", C_NAME, "emit", "library", ...
set(kiln_row_regex
    "\nKILN_(CROSS_)?TARGET\\(([A-Za-z0-9]+), *([a-z0-9_]+), *\"[^\"]*\", *\"[^\"]*\", *[A-Z0-9_]+, *\"([a-z0-9-]*)\", *\"([a-z0-9-]*)\"")
string(REGEX MATCHALL "${kiln_row_regex}" kiln_target_rows "${kiln_targets_text}")
if(NOT kiln_target_rows)
  message(FATAL_ERROR "kiln: no target rows in ${KILN_TARGETS_DEF}")
endif()
set(KILN_TARGET_IDS)
set(KILN_TARGET_EMIT_STAGES variants preprocessed)
set(KILN_CROSS_TARGET_SOURCES)
set(kiln_target_libraries)
foreach(row IN LISTS kiln_target_rows)
  string(REGEX MATCH "${kiln_row_regex}" row "${row}")
  list(APPEND KILN_TARGET_IDS ${CMAKE_MATCH_3})
  list(APPEND KILN_TARGET_EMIT_STAGES ${CMAKE_MATCH_4})
  if(CMAKE_MATCH_1)
    list(APPEND KILN_CROSS_TARGET_SOURCES src/cross/${CMAKE_MATCH_3}_target.cpp)
  endif()
  if(CMAKE_MATCH_5)
    list(APPEND kiln_target_libraries ${CMAKE_MATCH_5})
  endif()
endforeach()
list(APPEND KILN_TARGET_EMIT_STAGES reflection)
list(REMOVE_DUPLICATES KILN_TARGET_EMIT_STAGES)
list(REMOVE_DUPLICATES kiln_target_libraries)
set(KILN_SPIRV_CROSS_LIBRARIES spirv-cross-core ${kiln_target_libraries} spirv-cross-reflect)
list(REVERSE kiln_target_libraries)  # SPIRV-Cross's MSL back end derives from its GLSL one
set(KILN_SPIRV_CROSS_LINK_ORDER ${kiln_target_libraries} spirv-cross-reflect spirv-cross-core)
