# `cpack -G DEB` (from the build directory): one Debian package, kiln, with everything `cmake --install` installs:
# kiln, kiln-worker and kiln-verify, the reader library and its headers, the CMake package, the pack and scene
# schemas, the man page and the bash completion. Installed under /usr, where find_package(kiln) finds it.
#
# Depends: the shared libraries the three executables link, found by dpkg-shlibdeps (glslang and SPIRV-Tools are
# linked statically on Debian 12 and need nothing at run time), plus what a project that links the reader or
# calls find_package(kiln) or pkg-config's kiln-reader needs: libxxhash and libzstd (the reader is a static
# library) and pkg-config. nlohmann-json is not needed: no installed header includes it. Tested by package.deb (fields, contents, a consumer project built against
# the unpacked package) and package.fresh_debian (installed with apt into a fresh Debian 12 chroot).
set(CPACK_GENERATOR DEB)
set(CPACK_PACKAGE_NAME kiln)
set(CPACK_PACKAGE_VENDOR "kiln")
set(CPACK_PACKAGE_CONTACT "kiln maintainers <kiln@example.org>")
set(CPACK_PACKAGE_DESCRIPTION_SUMMARY "shader permutation build system: HLSL to SPIR-V, GLSL, GLSL ES and MSL variant packs")
set(CPACK_PACKAGE_DESCRIPTION
    "kiln reads HLSL whose keyword pragmas describe shader variants, expands and strips the permutations, compiles "
    "each distinct stage once (glslang, SPIRV-Tools, SPIRV-Cross) and writes variant packs with a runtime reader. "
    "This package holds the kiln CLI and its worker, kiln-verify (rendering on lavapipe/llvmpipe), the pack reader "
    "library and headers, the CMake package (find_package(kiln), kiln_add_shader_pack) and the JSON schemas.")
set(CPACK_PACKAGING_INSTALL_PREFIX /usr)
set(CPACK_DEBIAN_FILE_NAME DEB-DEFAULT)
set(CPACK_DEBIAN_PACKAGE_SECTION devel)
set(CPACK_DEBIAN_PACKAGE_SHLIBDEPS ON)
set(CPACK_DEBIAN_PACKAGE_DEPENDS "libxxhash-dev, libzstd-dev, pkgconf | pkg-config")
set(CPACK_DEBIAN_PACKAGE_RECOMMENDS "cmake (>= 3.25), mesa-vulkan-drivers, libgl1-mesa-dri")
set(CPACK_DEBIAN_PACKAGE_HOMEPAGE "https://example.org/kiln")
set(CPACK_STRIP_FILES ON)
include(CPack)
