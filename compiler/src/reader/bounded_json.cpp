// SPDX-License-Identifier: Apache-2.0
#include "kiln/bounded_json.hpp"

#include <iterator>
#include <string>
#include <unordered_set>
#include <vector>

namespace kiln {
namespace {

using nlohmann::json;

// A character iterator that records how far nlohmann's lexer has read: SAX events carry no position, so a repeated
// key or a nesting too deep is located at the byte the lexer had reached when it was reported.
class TrackedIterator {
 public:
  using iterator_category = std::forward_iterator_tag;
  using value_type = char;
  using difference_type = std::ptrdiff_t;
  using pointer = const char*;
  using reference = const char&;

  TrackedIterator(const char* at, const char** furthest) : at_(at), furthest_(furthest) {}
  reference operator*() const { return *at_; }
  TrackedIterator& operator++() {
    ++at_;
    if (at_ > *furthest_) *furthest_ = at_;
    return *this;
  }
  TrackedIterator operator++(int) {
    TrackedIterator before = *this;
    ++*this;
    return before;
  }
  bool operator==(const TrackedIterator& other) const { return at_ == other.at_; }
  bool operator!=(const TrackedIterator& other) const { return at_ != other.at_; }

 private:
  const char* at_;
  const char** furthest_;
};

// nlohmann's DOM builder with the checks nlohmann does not make: depth (refused at the opening bracket, before the
// reader recurses into it) and repeated keys. The first problem stops the parse; its message and offset are kept.
class BoundedSax {
 public:
  BoundedSax(json& root, size_t max_depth, const char* begin, const char** furthest)
      : dom_(root, /*allow_exceptions=*/false), max_depth_(max_depth), begin_(begin), furthest_(furthest) {}

  bool null() { return dom_.null(); }
  bool boolean(bool value) { return dom_.boolean(value); }
  bool number_integer(json::number_integer_t value) { return dom_.number_integer(value); }
  bool number_unsigned(json::number_unsigned_t value) { return dom_.number_unsigned(value); }
  bool number_float(json::number_float_t value, const json::string_t& text) { return dom_.number_float(value, text); }
  bool string(json::string_t& value) { return dom_.string(value); }
  bool binary(json::binary_t& value) { return dom_.binary(value); }
  bool start_object(size_t size) {
    if (!enter()) return false;
    keys_.emplace_back();
    return dom_.start_object(size);
  }
  bool key(json::string_t& name) {
    if (!keys_.empty() && !keys_.back().insert(name).second)
      return fail("the key " + json(name).dump() + " appears twice in one object (JSON does not say which one counts)");
    return dom_.key(name);
  }
  bool end_object() {
    --depth_;
    if (!keys_.empty()) keys_.pop_back();
    return dom_.end_object();
  }
  bool start_array(size_t size) { return enter() && dom_.start_array(size); }
  bool end_array() {
    --depth_;
    return dom_.end_array();
  }
  bool parse_error(size_t position, const std::string& token, const nlohmann::detail::exception& error) {
    offset_ = position > 0 ? position - 1 : 0;
    if (error.id == 406) {  // a number outside the double range: at the number's first digit, and not all of it
      offset_ = position >= token.size() ? position - token.size() : 0;
      message_ = "number overflow parsing '" +
                 (token.size() > 40 ? token.substr(0, 32) + "...' (" + std::to_string(token.size()) + " characters)"
                                    : token + "'");
      return false;
    }
    std::string reason = error.what();
    // "[json.exception.parse_error.101] parse error at line 1, column 2: syntax error ..." -> "syntax error ...".
    if (size_t end = reason.find("] "); reason.starts_with("[json.exception.") && end != std::string::npos)
      reason = reason.substr(end + 2);
    if (reason.starts_with("parse error"))
      if (size_t colon = reason.find(": "); colon != std::string::npos) reason = reason.substr(colon + 2);
    message_ = reason;
    return false;
  }

  const std::string& message() const { return message_; }
  size_t offset() const { return offset_; }

 private:
  bool enter() {
    if (++depth_ > max_depth_)
      return fail("arrays and objects are nested more than " + std::to_string(max_depth_) + " deep");
    return true;
  }
  bool fail(const std::string& message) {
    message_ = message;
    offset_ = *furthest_ > begin_ ? static_cast<size_t>(*furthest_ - begin_) - 1 : 0;
    return false;
  }

  nlohmann::detail::json_sax_dom_parser<json> dom_;
  size_t max_depth_;
  size_t depth_ = 0;
  std::vector<std::unordered_set<std::string>> keys_;  // the keys seen in each open object
  const char* begin_;
  const char** furthest_;
  std::string message_;
  size_t offset_ = 0;
};

json decode(std::string_view bytes, JsonLimits limits, nlohmann::detail::input_format_t format) {
  if (bytes.size() > limits.max_bytes)
    throw JsonDecodeError(std::to_string(bytes.size()) + " bytes, over the limit of " + std::to_string(limits.max_bytes),
                          0);
  json root;
  const char* furthest = bytes.data();
  BoundedSax sax(root, limits.max_depth, bytes.data(), &furthest);
  bool ok = false;
  try {
    ok = json::sax_parse(TrackedIterator(bytes.data(), &furthest), TrackedIterator(bytes.data() + bytes.size(), &furthest),
                         &sax, format);
  } catch (const json::exception& error) {
    // The DOM builder throws for what it refuses itself (an array or object larger than max_size()).
    throw JsonDecodeError(error.what(), static_cast<size_t>(furthest - bytes.data()));
  }
  if (!ok) throw JsonDecodeError(sax.message().empty() ? "malformed input" : sax.message(), sax.offset());
  return root;
}

}  // namespace

json parse_json_bounded(std::string_view text, JsonLimits limits) {
  return decode(text, limits, nlohmann::detail::input_format_t::json);
}

json decode_cbor_bounded(std::string_view bytes, JsonLimits limits) {
  return decode(bytes, limits, nlohmann::detail::input_format_t::cbor);
}

}  // namespace kiln
