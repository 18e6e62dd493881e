// SPDX-License-Identifier: Apache-2.0
// kiln's one result type: a value, or the error that says why there is none. Every library function that can fail
// for a reason its caller reports returns one (instead of a bool with a std::string& out-parameter, or a struct of
// its own with `ok` and `error`); the reader's noexcept calls return its PackResult, a Result whose error is a
// PackError.
//
// Its shape is C++23's std::expected (has_value, value, error, operator*, operator->; `return kiln::failure(e)` for
// `return std::unexpected(e)`), so that it becomes an alias when kiln's compilers have <expected>. Header-only and
// free of exceptions: it is installed with the reader, which games compile with -fno-exceptions.
//
// What stays out, on purpose: the front end's results and a compile job's JobOutput carry warnings when they succeed
// and several located messages when they fail (they are a compile's outcome, not an error channel); diagnostics
// go to a DiagnosticSink.
#pragma once

#include <cassert>
#include <string>
#include <type_traits>
#include <utility>
#include <variant>

namespace kiln {

// What a library function says when it fails: a sentence for the user, in kiln's wording ("cannot write x: ...").
struct Error {
  std::string message;
};

// The error a Result is made from (std::unexpected).
template <class E>
struct Failure {
  E error;
};
template <class E>
Failure<std::decay_t<E>> failure(E&& error) {
  return {std::forward<E>(error)};
}
inline Failure<Error> failure(std::string message) { return {Error{std::move(message)}}; }
inline Failure<Error> failure(const char* message) { return {Error{message}}; }

template <class T, class E = Error>
class [[nodiscard]] Result {
 public:
  Result(T value) : state_(std::in_place_index<0>, std::move(value)) {}  // NOLINT(google-explicit-constructor)
  template <class F>
    requires std::is_constructible_v<E, F&&>
  Result(Failure<F> failed) : state_(std::in_place_index<1>, E(std::move(failed.error))) {}  // NOLINT

  bool has_value() const noexcept { return state_.index() == 0; }
  explicit operator bool() const noexcept { return has_value(); }

  // The value; only when has_value().
  T& value() & noexcept { return *checked_value(); }
  const T& value() const& noexcept { return *const_cast<Result*>(this)->checked_value(); }
  T&& value() && noexcept { return std::move(*checked_value()); }
  T& operator*() & noexcept { return value(); }
  const T& operator*() const& noexcept { return value(); }
  T&& operator*() && noexcept { return std::move(*this).value(); }
  T* operator->() noexcept { return &value(); }
  const T* operator->() const noexcept { return &value(); }

  // The error; only when !has_value().
  const E& error() const& noexcept {
    assert(!has_value());
    return *std::get_if<1>(&state_);
  }
  E&& error() && noexcept {
    assert(!has_value());
    return std::move(*std::get_if<1>(&state_));
  }

 private:
  T* checked_value() noexcept {
    assert(has_value());
    return std::get_if<0>(&state_);
  }
  std::variant<T, E> state_;
};

// A function with nothing to return but a failure.
template <class E>
class [[nodiscard]] Result<void, E> {
 public:
  Result() = default;
  template <class F>
    requires std::is_constructible_v<E, F&&>
  Result(Failure<F> failed) : error_(E(std::move(failed.error))), failed_(true) {}  // NOLINT

  bool has_value() const noexcept { return !failed_; }
  explicit operator bool() const noexcept { return has_value(); }
  const E& error() const& noexcept {
    assert(failed_);
    return error_;
  }

 private:
  E error_{};
  bool failed_ = false;
};

}  // namespace kiln
