# SPDX-License-Identifier: Apache-2.0
# `cpack -G DEB` (from the build directory): four Debian packages, split as Debian splits a library and its tools, so
# that each user installs only what they need:
#   libkiln-reader0     libkiln_reader.so.0, what a game ships (the reader's C and C++ API; libc, libstdc++, xxHash
#                       and zstd at run time)
#   libkiln-reader-dev  the reader's headers, libkiln_reader.so and .a, kiln-reader.pc and find_package(kiln)'s
#                       reader part: what a game builds with (`cc game.c $(pkg-config --cflags --libs kiln-reader)`
#                       links with the C compiler alone); and the development reader for a game's development
#                       builds (libkiln_reader_dev.a, kiln-reader-dev.pc, COMPONENTS reader_dev), whose libcurl is
#                       suggested, not depended on: libkiln-reader0 and a release build never need it
#   kiln                kiln and kiln-worker, find_package(kiln)'s compiler part (kiln_add_shader_pack), the
#                       schemas, man page, completion, docs and examples: what a build machine or a lint job needs,
#                       with no Vulkan, EGL or X11 (it recommends libkiln-reader-dev, whose config file loads it)
#   kiln-verify         kiln-verify (kiln render, kiln test): Vulkan, EGL, PNG and OpenEXR
# Each holds its copyright file and a compressed Debian changelog (lintian). Depends: the shared libraries each
# package's files link (dpkg-shlibdeps; glslang and SPIRV-Tools are static on Debian 12) and the packages below it.
# Tested by package.deb (fields, contents, lintian, a C program and a consumer project against the unpacked packages)
# and package.fresh_debian (installed with apt into a fresh Debian 12 chroot).
set(CPACK_GENERATOR DEB)
set(CPACK_PACKAGE_NAME kiln)
set(CPACK_PACKAGE_VENDOR "kiln")
set(CPACK_PACKAGE_CONTACT "kiln maintainers <kiln@example.org>")
set(CPACK_PACKAGING_INSTALL_PREFIX /usr)
set(CPACK_DEBIAN_FILE_NAME DEB-DEFAULT)
# Debian revision 1: a package built from kiln's source, not a native Debian package (its changelog is then
# changelog.Debian.gz).
set(CPACK_DEBIAN_PACKAGE_RELEASE 1)
set(CPACK_DEBIAN_PACKAGE_HOMEPAGE "https://example.org/kiln")
set(CPACK_DEBIAN_PACKAGE_SHLIBDEPS ON)
# A shlibs file for the package that holds a shared library (libkiln-reader0): what a program linking it depends on.
set(CPACK_DEBIAN_PACKAGE_GENERATE_SHLIBS ON)
set(CPACK_DEBIAN_PACKAGE_GENERATE_SHLIBS_POLICY ">=")
set(CPACK_STRIP_FILES ON)

set(CPACK_DEB_COMPONENT_INSTALL ON)
set(CPACK_COMPONENTS_ALL reader dev cli)
if(TARGET kiln-verify)
  list(APPEND CPACK_COMPONENTS_ALL verify)
endif()
set(CPACK_DEBIAN_ENABLE_COMPONENT_DEPENDS ON)
set(CPACK_COMPONENT_DEV_DEPENDS reader)
set(CPACK_COMPONENT_VERIFY_DEPENDS cli)

# Synopses under 80 characters and description lines under 80 (lintian); the first line of each is its synopsis.
set(kiln_about "kiln reads HLSL whose keyword pragmas describe shader variants, expands
and strips the permutations, compiles each distinct stage once (glslang,
SPIRV-Tools, SPIRV-Cross) and writes variant packs with a runtime reader.")

set(CPACK_DEBIAN_READER_PACKAGE_NAME libkiln-reader0)
set(CPACK_DEBIAN_READER_PACKAGE_SECTION libs)
set(CPACK_DEBIAN_READER_DESCRIPTION "runtime reader for kiln shader variant packs
${kiln_about}
This package holds the reader library a game links and ships: it opens a
pack, selects a variant by keywords and hands out its code for each stage
and target.")
# Debian runs ldconfig for a shared library through this trigger (lintian: lacks-ldconfig-trigger).
file(WRITE ${PROJECT_BINARY_DIR}/debian/triggers "activate-noawait ldconfig\n")
set(CPACK_DEBIAN_READER_PACKAGE_CONTROL_EXTRA ${PROJECT_BINARY_DIR}/debian/triggers)

set(CPACK_DEBIAN_DEV_PACKAGE_NAME libkiln-reader-dev)
set(CPACK_DEBIAN_DEV_PACKAGE_SECTION libdevel)
# A static link of libkiln_reader.a (pkg-config --static) needs xxHash's and zstd's development files and the C++
# runtime's (libstdc++.a: a C program has no g++ to bring it); kiln-reader.pc needs pkg-config itself.
set(CPACK_DEBIAN_DEV_PACKAGE_DEPENDS "libxxhash-dev, libzstd-dev, libstdc++-12-dev | libstdc++-dev, pkgconf | pkg-config")
# kiln::reader_dev (development builds only) links libcurl: find_package(kiln COMPONENTS reader_dev) names the package.
set(CPACK_DEBIAN_DEV_PACKAGE_SUGGESTS "libcurl4-openssl-dev | libcurl-dev")
set(CPACK_DEBIAN_DEV_DESCRIPTION "runtime reader for kiln shader variant packs (development files)
${kiln_about}
This package holds what a game builds with: the reader's C and C++
headers, the shared and static libraries, and kiln-reader.pc for pkg-config;
and the development reader (kiln-reader-dev.pc), which asks kiln watch for
the variants a development build lacks.")

set(CPACK_DEBIAN_CLI_PACKAGE_NAME kiln)
set(CPACK_DEBIAN_CLI_PACKAGE_SECTION devel)
set(CPACK_DEBIAN_CLI_PACKAGE_DEPENDS "pkgconf | pkg-config")
# find_package(kiln)'s config file is the reader's developer package's (the compiler's part is loaded from it).
set(CPACK_DEBIAN_CLI_PACKAGE_RECOMMENDS "libkiln-reader-dev (= ${PROJECT_VERSION}-${CPACK_DEBIAN_PACKAGE_RELEASE}), cmake (>= 3.25)")
set(CPACK_DEBIAN_CLI_PACKAGE_SUGGESTS "kiln-verify")
set(CPACK_DEBIAN_CLI_DESCRIPTION "shader permutation build system (HLSL to SPIR-V, GLSL, MSL)
${kiln_about}
This package holds the kiln command line and its compiler worker, the CMake
package (find_package(kiln), kiln_add_shader_pack), the pack and scene JSON
schemas, the manual and examples.")

set(CPACK_DEBIAN_VERIFY_PACKAGE_NAME kiln-verify)
set(CPACK_DEBIAN_VERIFY_PACKAGE_SECTION devel)
set(CPACK_DEBIAN_VERIFY_PACKAGE_RECOMMENDS "mesa-vulkan-drivers, libgl1-mesa-dri")
set(CPACK_DEBIAN_VERIFY_DESCRIPTION "renders kiln variant packs and compares them with reference images
${kiln_about}
This package holds kiln-verify, which kiln render and kiln test run: it
draws every variant of a pack on Mesa lavapipe (Vulkan) and llvmpipe
(OpenGL 4.5, OpenGL ES 3.2) and compares the images with golden images
from a CPU reference.")

# Each package's copyright and changelog.Debian.gz, in /usr/share/doc/<package> (the changelog dated by
# SOURCE_DATE_EPOCH when set, for reproducible packages).
find_program(KILN_GZIP gzip REQUIRED)
string(TIMESTAMP KILN_DEB_DATE "%a, %d %b %Y %H:%M:%S +0000" UTC)
foreach(component IN LISTS CPACK_COMPONENTS_ALL)
  string(TOUPPER ${component} upper)
  set(KILN_DEB_PACKAGE ${CPACK_DEBIAN_${upper}_PACKAGE_NAME})
  set(dir ${PROJECT_BINARY_DIR}/debian/${KILN_DEB_PACKAGE})
  configure_file(${PROJECT_SOURCE_DIR}/cmake/debian/changelog.in ${dir}/changelog.Debian @ONLY)
  execute_process(COMMAND ${KILN_GZIP} -9nf ${dir}/changelog.Debian COMMAND_ERROR_IS_FATAL ANY)
  install(FILES ${PROJECT_SOURCE_DIR}/cmake/debian/copyright ${dir}/changelog.Debian.gz
          DESTINATION ${CMAKE_INSTALL_DATAROOTDIR}/doc/${KILN_DEB_PACKAGE} COMPONENT ${component})
endforeach()
include(CPack)
