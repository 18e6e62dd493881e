// SPDX-License-Identifier: Apache-2.0
// The one decoder of JSON and CBOR from outside (kiln/bounded_json.hpp), and the compile record decoder on it: a
// forged remote record of 200,000 nested CBOR arrays crashed `kiln build` on a transfer thread.
#include <gtest/gtest.h>

#include <string>

#include "common/compile_result.hpp"
#include "kiln/bounded_json.hpp"

namespace kiln {
namespace {

constexpr JsonLimits kLimits{size_t{1} << 30, kMaxJsonDepth};

std::string decode_error(const std::string& bytes, bool cbor, size_t* offset = nullptr) {
  try {
    cbor ? decode_cbor_bounded(bytes, kLimits) : parse_json_bounded(bytes, kLimits);
  } catch (const JsonDecodeError& error) {
    if (offset) *offset = error.offset();
    return error.what();
  }
  return "decoded";
}

// CBOR: 0x81 opens an array of one element; 0xf6 is null.
std::string nested_cbor(size_t depth) { return std::string(depth, '\x81') + '\xf6'; }

TEST(BoundedJson, CborNestedDeeperThanTheLimitIsRefusedBeforeTheStackRunsOut) {
  EXPECT_EQ(decode_error(nested_cbor(kMaxJsonDepth), true), "decoded");
  EXPECT_EQ(decode_error(nested_cbor(kMaxJsonDepth + 1), true), "arrays and objects are nested more than 64 deep");
  EXPECT_EQ(decode_error(nested_cbor(200000), true), "arrays and objects are nested more than 64 deep");
}

TEST(BoundedJson, AForgedCompileRecordIsAnErrorNotACrash) {
  const std::string forged = nested_cbor(200000);
  EXPECT_THROW(decode_output(std::vector<uint8_t>(forged.begin(), forged.end())), std::exception);
  JobOutput good;
  good.ok = true;
  good.messages.push_back({Severity::Warning, "a.hlsl", 3, "text", 4});
  EXPECT_EQ(decode_output(encode_output(good)).messages.at(0).text, "text");
}

TEST(BoundedJson, TextNestedDeeperThanTheLimitIsRefusedAtItsBracket) {
  size_t offset = 0;
  EXPECT_EQ(decode_error(std::string(64, '[') + std::string(64, ']'), false), "decoded");
  EXPECT_EQ(decode_error("{\"a\": " + std::string(200000, '[') + std::string(200000, ']') + "}", false, &offset),
            "arrays and objects are nested more than 64 deep");
  EXPECT_EQ(offset, 6u + 63u);  // the 64th '[' after `{"a": ` opens level 65
}

TEST(BoundedJson, NumbersOutsideTheDoubleRangeAreErrorsAtTheirOffset) {
  for (const std::string& number : {std::string("1e400"), std::string("-1e400"), std::string(1000000, '7')}) {
    size_t offset = 0;
    const std::string error = decode_error("{\"n\": " + number + "}", false, &offset);
    EXPECT_EQ(error.rfind("number overflow parsing '", 0), 0u) << error.substr(0, 80);
    EXPECT_GE(offset, 6u);
  }
  EXPECT_EQ(decode_error("[1e300, -1e300, 18446744073709551615]", false), "decoded");
}

TEST(BoundedJson, AKeyTwiceInOneObjectIsAnErrorNotLastWins) {
  size_t offset = 0;
  EXPECT_EQ(decode_error("{\"a\": 1, \"b\": {\"a\": 2}, \"a\": 3}", false, &offset),
            "the key \"a\" appears twice in one object (JSON does not say which one counts)");
  EXPECT_EQ(offset, 26u);  // the second "a"'s closing quote
  EXPECT_EQ(decode_error("[{\"a\": 1}, {\"a\": 2}]", false), "decoded");  // one key in each of two objects
}

TEST(BoundedJson, InputOverTheSizeLimitIsRefusedBeforeItIsParsed) {
  try {
    parse_json_bounded("[1, 2, 3]", {4, kMaxJsonDepth});
    FAIL() << "parsed";
  } catch (const JsonDecodeError& error) {
    EXPECT_EQ(std::string(error.what()), "9 bytes, over the limit of 4");
  }
}

TEST(BoundedJson, SyntaxErrorsKeepNlohmannsReasonAndOffset) {
  size_t offset = 0;
  EXPECT_EQ(decode_error("{\"a\": 1,}", false, &offset),
            "syntax error while parsing object key - unexpected '}'; expected string literal");
  EXPECT_EQ(offset, 8u);
  EXPECT_NE(decode_error("\xff", true), "decoded");  // a CBOR break code with nothing to end
}

}  // namespace
}  // namespace kiln
