# SPDX-License-Identifier: Apache-2.0
# A cross build as far as CMake can tell: another system name makes CMAKE_CROSSCOMPILING true, and packages are
# looked up in a fake sysroot (the test's copy of an installed kiln, whose kiln cannot run on the build machine)
# before the host root (for nlohmann_json and the other dependencies of kilnConfig.cmake).
set(CMAKE_SYSTEM_NAME Linux)
set(CMAKE_SYSTEM_PROCESSOR kiln-fake-target)
set(CMAKE_FIND_ROOT_PATH "$ENV{KILN_FAKE_SYSROOT};/")
set(CMAKE_FIND_ROOT_PATH_MODE_PROGRAM NEVER)
set(CMAKE_FIND_ROOT_PATH_MODE_LIBRARY ONLY)
set(CMAKE_FIND_ROOT_PATH_MODE_INCLUDE ONLY)
set(CMAKE_FIND_ROOT_PATH_MODE_PACKAGE ONLY)
