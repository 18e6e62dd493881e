// SPDX-License-Identifier: Apache-2.0
// Fault injection for the test builds of kiln's executables (kiln-fault-cli, kiln-verify-fault; never the shipped
// ones, which do not include this file): KILN_INJECT_FAULT=VERB:KIND makes verb VERB throw, once its arguments are
// parsed, an exception of KIND: runtime_error, filesystem_error, bad_alloc or unknown (not an std::exception). The
// tests check that every verb reports it through the one guarded entry point (kiln/guarded_main.hpp).
#pragma once

#include <cstdlib>
#include <filesystem>
#include <new>
#include <stdexcept>
#include <string>
#include <string_view>
#include <system_error>

namespace kiln::testing {

inline void inject_fault(std::string_view verb) {
  const char* setting = std::getenv("KILN_INJECT_FAULT");
  if (!setting) return;
  const std::string_view text(setting);
  const size_t colon = text.find(':');
  if (colon == std::string_view::npos || text.substr(0, colon) != verb) return;
  const std::string_view kind = text.substr(colon + 1);
  const std::string what = "injected into '" + std::string(verb) + "'";
  if (kind == "runtime_error") throw std::runtime_error(what);
  if (kind == "filesystem_error")
    throw std::filesystem::filesystem_error(what, "/injected/path", std::make_error_code(std::errc::io_error));
  if (kind == "bad_alloc") throw std::bad_alloc();
  if (kind == "unknown") throw 42;
}

}  // namespace kiln::testing
