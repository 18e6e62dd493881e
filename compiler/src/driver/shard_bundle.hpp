// SPDX-License-Identifier: Apache-2.0
// A shard's results as one object (--shard I/N; docs/remote-cache.md, "Sharding a build over machines"): every stage
// source of its share with its source key, its module's key and output (the blobs inside), and its front end's
// messages. The merge fetches one bundle per shard instead of one entry per stage source, and uses each as a
// cache hit: nothing in it is trusted until decode_shard_bundle has checked it.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "common/compile_result.hpp"
#include "common/hash.hpp"
#include "kiln/result.hpp"

namespace kiln {

struct ShardBundle {
  uint32_t index = 0;
  uint32_t count = 1;
  uint64_t source_count = 0;     // the plan's stage sources, every share's
  std::vector<JobOutput> outputs;  // distinct module outputs, blobs included
  struct Source {
    uint32_t source = 0;    // index into the plan's stage sources
    uint64_t identity = 0;  // source_identity (driver/stage_sources.hpp): the merge checks it is the same source
    Hash128 key;            // its source key
    Hash128 module;         // its module's key
    uint32_t output = 0;    // into outputs
    std::vector<FrontendMessage> messages;  // the front end's, when the output does not already start with them
  };
  std::vector<Source> sources;
};

std::string encode_shard_bundle(const ShardBundle& bundle);
// The same, with the outputs given apart (bundle.outputs is not read): a shard's own, not copied.
std::string encode_shard_bundle(const ShardBundle& bundle, const std::vector<const JobOutput*>& outputs);

// The bundle, when every field is in bounds and every output decodes, is a good result and has blobs that unpack to
// the size and checksum they give and hash to their key (the checks a remote entry gets, on `threads` threads);
// else the error says what is wrong.
Result<ShardBundle> decode_shard_bundle(std::string_view bytes, unsigned threads);

}  // namespace kiln
