// SPDX-License-Identifier: Apache-2.0
// A shard's bundle (driver/shard_bundle.hpp) comes from a server other machines write: it decodes to what was
// encoded, and anything else (cut short anywhere, a byte changed anywhere, a blob that does not unpack to its hash)
// is an error, never a crash or a bundle that names what it does not hold.
#include <gtest/gtest.h>

#include "common/blob.hpp"
#include "driver/shard_bundle.hpp"

namespace kiln {
namespace {

ShardBundle sample() {
  ShardBundle bundle;
  bundle.index = 1;
  bundle.count = 3;
  bundle.source_count = 7;
  for (const char* text : {"first module's SPIR-V, as bytes", "second module's"}) {
    JobOutput output;
    output.ok = true;
    output.blobs[Target::Spirv] = pack_blob(std::string(text) + std::string(300, 'x'));
    output.messages = {{Severity::Warning, "S.hlsl", 3, "a back-end warning"}};
    if (bundle.outputs.empty()) {  // the first with a reflection, GLSL bindings and the full legalization
      output.blobs[Target::Glsl] = pack_blob("#version 450\n" + std::string(500, ' '));
      Resource buffer{"Frame", ResourceKind::UniformBuffer, 0, 2, 1, 64, {{"view", 0, 64, "float4x4", std::nullopt}}};
      output.reflection.resources.push_back(buffer);
      output.reflection.inputs.push_back({"in_position", 0, "float3", "POSITION"});
      output.reflection.glsl = GlBindings{{}, {{"Frame", ResourceKind::UniformBuffer, 2}}};
      output.full_legalization = true;
      output.spirv = {0x07230203u, 0x00010000u};
    }
    bundle.outputs.push_back(output);
  }
  for (uint32_t source : {1u, 4u}) {
    ShardBundle::Source& s = bundle.sources.emplace_back();
    s.source = source;
    s.identity = 100 + source;
    s.key = Hash128{source, 2};
    s.module = Hash128{source, 3};
    s.output = source == 1 ? 0 : 1;
    if (source == 4) s.messages = {{Severity::Warning, "S.hlsl", 9, "a front-end warning", 4}};
  }
  return bundle;
}

TEST(ShardBundle, DecodesToWhatWasEncoded) {
  const ShardBundle bundle = sample();
  Result<ShardBundle> decoded = decode_shard_bundle(encode_shard_bundle(bundle), 2);
  ASSERT_TRUE(decoded) << decoded.error().message;
  EXPECT_EQ(decoded->index, 1u);
  EXPECT_EQ(decoded->count, 3u);
  EXPECT_EQ(decoded->source_count, 7u);
  ASSERT_EQ(decoded->outputs.size(), 2u);
  for (size_t o = 0; o < 2; ++o) {
    const JobOutput &got = decoded->outputs[o], &sent = bundle.outputs[o];
    EXPECT_TRUE(got.ok);
    EXPECT_EQ(got.blobs, sent.blobs) << o;
    EXPECT_EQ(got.reflection, sent.reflection) << o;
    EXPECT_EQ(got.full_legalization, sent.full_legalization) << o;
    EXPECT_EQ(got.spirv, sent.spirv) << o;
    ASSERT_EQ(got.messages.size(), 1u) << o;
    EXPECT_EQ(got.messages[0].text, "a back-end warning");
    EXPECT_EQ(got.messages[0].line, 3);
  }
  EXPECT_EQ(decoded->outputs[0].blobs.size(), 2u);
  EXPECT_EQ(decoded->outputs[0].reflection.glsl->blocks.at(0).binding, 2u);
  ASSERT_EQ(decoded->sources.size(), 2u);
  EXPECT_EQ(decoded->sources[1].source, 4u);
  EXPECT_EQ(decoded->sources[1].identity, 104u);
  EXPECT_EQ(decoded->sources[1].key, (Hash128{4, 2}));
  EXPECT_EQ(decoded->sources[1].module, (Hash128{4, 3}));
  EXPECT_EQ(decoded->sources[1].output, 1u);
  ASSERT_EQ(decoded->sources[1].messages.size(), 1u);
  EXPECT_EQ(decoded->sources[1].messages[0].column, 4);
}

TEST(ShardBundle, EveryCutIsAnError) {
  const std::string bytes = encode_shard_bundle(sample());
  for (size_t size = 0; size < bytes.size(); ++size)
    EXPECT_FALSE(decode_shard_bundle(std::string_view(bytes).substr(0, size), 1)) << "cut at " << size;
  EXPECT_FALSE(decode_shard_bundle(bytes + "x", 1)) << "a byte after the end";
}

// Every byte changed in turn: an error, or a bundle whose every index is in bounds (a changed key or identity is
// not the decoder's to see: the merge checks identities against its plan, and keys are the shard's word, as a
// remote record's are).
TEST(ShardBundle, EveryChangedByteIsAnErrorOrStaysInBounds) {
  const std::string bytes = encode_shard_bundle(sample());
  size_t refused = 0;
  for (size_t at = 0; at < bytes.size(); ++at) {
    std::string changed = bytes;
    changed[at] = static_cast<char>(changed[at] ^ 0x41);
    Result<ShardBundle> decoded = decode_shard_bundle(changed, 1);
    if (!decoded) {
      ++refused;
      continue;
    }
    EXPECT_LT(decoded->index, decoded->count) << at;
    for (const ShardBundle::Source& s : decoded->sources) {
      EXPECT_LT(s.source, decoded->source_count) << at;
      EXPECT_LT(s.output, decoded->outputs.size()) << at;
    }
    for (const JobOutput& output : decoded->outputs)
      for (const auto& [target, blob] : output.blobs) EXPECT_EQ(hash128(unpack_blob(blob)), blob.key) << at;
  }
  EXPECT_GT(refused, bytes.size() / 2);
}

TEST(ShardBundle, ABlobThatDoesNotUnpackToItsHashIsRefused) {
  ShardBundle bundle = sample();
  bundle.outputs[1].blobs.at(Target::Spirv).key.low ^= 1;
  Result<ShardBundle> decoded = decode_shard_bundle(encode_shard_bundle(bundle), 2);
  ASSERT_FALSE(decoded);
  EXPECT_EQ(decoded.error().message, "a shard bundle's blob does not unpack to its size, checksum and hash");
}

TEST(ShardBundle, CountsTheBytesCannotHoldAreRefusedBeforeAnythingIsReserved) {
  std::string bytes = encode_shard_bundle(sample());
  for (int i = 0; i < 4; ++i) bytes[32 + i] = '\xff';  // the source count: 4 billion sources in a few hundred bytes
  Result<ShardBundle> decoded = decode_shard_bundle(bytes, 1);
  ASSERT_FALSE(decoded);
  EXPECT_EQ(decoded.error().message, "shard bundle cut short");
}

}  // namespace
}  // namespace kiln
