// SPDX-License-Identifier: Apache-2.0
// kiln/kiln_reader_dev.h over DevelopmentReader. The pack's PackReader comes from the reader's C API
// (kiln::pack_reader_of in src/reader/c_api.cpp); switches go through kiln_pack_poll_update so that the C pack's
// id tables follow the new pack.
#include "kiln/kiln_reader_dev.h"

#include <cstring>
#include <new>

#include "kiln/development_reader.hpp"

namespace kiln {
PackReader& pack_reader_of(kiln_pack& pack);  // src/reader/c_api.cpp
}

struct kiln_development {
  kiln_pack* pack = nullptr;
  kiln::DevelopmentReader reader;
};

namespace {

void fill(kiln_error* error, kiln_result code, const std::string& message, const std::string& file = {}) {
  if (!error) return;
  error->code = code;
  std::strncpy(error->message, message.c_str(), sizeof error->message - 1);
  error->message[sizeof error->message - 1] = '\0';
  std::strncpy(error->file, file.c_str(), sizeof error->file - 1);
  error->file[sizeof error->file - 1] = '\0';
}

template <class T>
kiln_result fill(kiln_error* error, const kiln::PackResult<T>& result) {
  const auto code = static_cast<kiln_result>(static_cast<int>(result.code()) + 1);  // kiln_reader.h mirrors PackError::Code
  fill(error, code, result.message(), result.file());
  return code;
}

std::vector<std::string> names(const char* const* keywords, size_t count) {
  std::vector<std::string> list;
  for (size_t i = 0; i < count; ++i) list.emplace_back(keywords[i]);
  return list;
}

}  // namespace

extern "C" {

kiln_result kiln_development_open(kiln_pack* pack, const char* manifest_path, const char* endpoint,
                                  kiln_development** development, kiln_error* error) {
  if (!pack || !manifest_path || !development) {
    fill(error, KILN_ERROR_INVALID_ARGUMENT, "kiln_development_open: a NULL pack, manifest path or result");
    return KILN_ERROR_INVALID_ARGUMENT;
  }
  try {
    kiln::DevelopmentReader::Options options;
    if (endpoint) options.endpoint = endpoint;
    kiln::PackResult<kiln::DevelopmentReader> opened = kiln::DevelopmentReader::open(kiln::pack_reader_of(*pack), manifest_path, options);
    if (!opened) return fill(error, opened);
    *development = new kiln_development{pack, std::move(*opened)};
  } catch (const std::bad_alloc&) {
    fill(error, KILN_ERROR_OUT_OF_MEMORY, "out of memory");
    return KILN_ERROR_OUT_OF_MEMORY;
  }
  fill(error, KILN_OK, "");
  return KILN_OK;
}

kiln_result kiln_development_from_environment(kiln_pack* pack, const char* manifest_path, kiln_development** development,
                                              kiln_error* error) {
  if (development) *development = nullptr;
  const char* value = std::getenv("KILN_DEVELOPMENT_ENDPOINT");
  if (!value || !*value) {
    fill(error, KILN_OK, "");
    return development ? KILN_OK : KILN_ERROR_INVALID_ARGUMENT;
  }
  return kiln_development_open(pack, manifest_path, std::strcmp(value, "auto") == 0 ? nullptr : value, development, error);
}

void kiln_development_close(kiln_development* development) { delete development; }

kiln_result kiln_development_poll_update(kiln_development* development, kiln_pack_update* update, kiln_error* error) {
  if (!development || !update) {
    fill(error, KILN_ERROR_INVALID_ARGUMENT, "kiln_development_poll_update: a NULL development reader or update");
    return KILN_ERROR_INVALID_ARGUMENT;
  }
  const kiln_result polled = kiln_pack_poll_update(development->pack, update, error);
  development->reader.report_selected();  // noexcept; a failed report is retried and said by last_error()
  return polled;
}

kiln_result kiln_development_select_or_wait(kiln_development* development, const char* pass, const char* const* keywords,
                                            size_t count, uint32_t timeout_ms, uint32_t* variant, kiln_error* error) {
  if (!development || !pass || (count && !keywords) || !variant) {
    fill(error, KILN_ERROR_INVALID_ARGUMENT, "kiln_development_select_or_wait: a NULL argument");
    return KILN_ERROR_INVALID_ARGUMENT;
  }
  const kiln_result selected = kiln_select_by_names(development->pack, pass, keywords, count, 0, variant, error);
  if (selected != KILN_ERROR_STRIPPED) return selected;
  try {
    kiln::PackResult<std::string> archive =
        development->reader.request(pass, names(keywords, count), std::chrono::milliseconds(timeout_ms));
    if (!archive) return fill(error, archive);
  } catch (const std::bad_alloc&) {
    fill(error, KILN_ERROR_OUT_OF_MEMORY, "out of memory");
    return KILN_ERROR_OUT_OF_MEMORY;
  }
  kiln_pack_update update;
  const kiln_result polled = kiln_pack_poll_update(development->pack, &update, error);
  if (polled != KILN_OK) return polled;
  return kiln_select_by_names(development->pack, pass, keywords, count, 0, variant, error);
}

kiln_result kiln_development_select_or_nearest(kiln_development* development, const char* pass, const char* const* keywords,
                                               size_t count, uint32_t* variant, int* nearest, kiln_error* error) {
  if (!development || !pass || (count && !keywords) || !variant || !nearest) {
    fill(error, KILN_ERROR_INVALID_ARGUMENT, "kiln_development_select_or_nearest: a NULL argument");
    return KILN_ERROR_INVALID_ARGUMENT;
  }
  try {
    kiln::PackResult<kiln::DevelopmentReader::Selection> selected = development->reader.select_or_nearest(pass, names(keywords, count));
    if (!selected) return fill(error, selected);
    *variant = static_cast<uint32_t>(selected->variant.index);
    *nearest = selected->nearest ? 1 : 0;
  } catch (const std::bad_alloc&) {
    fill(error, KILN_ERROR_OUT_OF_MEMORY, "out of memory");
    return KILN_ERROR_OUT_OF_MEMORY;
  }
  fill(error, KILN_OK, "");
  return KILN_OK;
}

}  // extern "C"
