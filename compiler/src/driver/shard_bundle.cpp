// SPDX-License-Identifier: Apache-2.0
#include "driver/shard_bundle.hpp"

#include <atomic>
#include <cstring>
#include <exception>
#include <optional>

#include "common/blob.hpp"
#include "common/bytes.hpp"
#include "common/parallel.hpp"
#include "kiln/pack_format.hpp"
#include "kiln/runtime_index.hpp"
#include "kiln/stage_target.hpp"

namespace kiln {
namespace {

constexpr char kBundleMagic[8] = {'K', 'I', 'L', 'N', 'S', 'H', 'R', 'D'};
// Format 2 carries each blob's bytes as they are, beside the output's CBOR (format 1 had them inside the CBOR, which
// the merge parsed a byte at a time).
constexpr uint32_t kBundleFormat = 2;
constexpr size_t kHeaderSize = 8 + 4 + 4 + 4 + 8 + 4 + 4;
constexpr size_t kSourceFixedSize = 4 + 8 + 16 + 16 + 4 + 8;
constexpr size_t kOutputFixedSize = 4 + 4 + 8 + 8 + 8;  // blob count, flags, SPIR-V, reflection and messages lengths
constexpr size_t kBlobFixedSize = 4 + 8 + 8 + 16 + 8;  // target, raw size, checksum, key, stored length
// A front end's messages and a reflection record are a few KiB; a blob is at most kMaxBlobBytes. These bound what one
// field of a hostile bundle makes kiln decode.
constexpr uint64_t kMaxMessagesBytes = uint64_t{16} << 20;

void put_hash(std::string& out, const Hash128& hash) {
  put64(out, hash.low);
  put64(out, hash.high);
}

void put_field(std::string& out, std::string_view bytes) {
  put64(out, bytes.size());
  out.append(bytes);
}

void put_cbor(std::string& out, const std::vector<uint8_t>& encoded) {
  put_field(out, std::string_view(reinterpret_cast<const char*>(encoded.data()), encoded.size()));
}

// Messages as the CBOR of an output that has only them; none as an empty field.
void put_messages(std::string& out, const std::vector<FrontendMessage>& messages) {
  if (messages.empty()) return put64(out, 0);
  JobOutput holder;
  holder.ok = true;
  holder.messages = messages;
  put_cbor(out, encode_output(holder));
}

std::optional<std::vector<FrontendMessage>> decode_messages(std::string_view field) {
  if (field.empty()) return std::vector<FrontendMessage>{};
  try {
    JobOutput holder = decode_output(field);
    if (!holder.ok || !holder.blobs.empty() || holder.messages.empty()) return std::nullopt;
    return std::move(holder.messages);
  } catch (const std::exception&) {
    return std::nullopt;
  }
}

// A good output: its blobs as they are stored (target, raw size, checksum, key, the bytes), whether it needed the
// full legalization, its SPIR-V words when it kept them, its reflection record (runtime::encode_reflection, the
// pack index's) and its messages.
void put_output(std::string& out, const JobOutput& output) {
  put32(out, static_cast<uint32_t>(output.blobs.size()));
  for (const auto& [target, blob] : output.blobs) {
    put32(out, static_cast<uint32_t>(target));
    put64(out, blob.raw_size);
    put64(out, blob.checksum);
    put_hash(out, blob.key);
    put_field(out, blob.stored);
  }
  put32(out, output.full_legalization ? 1 : 0);
  const std::vector<uint8_t> spirv = spirv_to_bytes(output.spirv);
  put_field(out, std::string_view(reinterpret_cast<const char*>(spirv.data()), spirv.size()));
  put_field(out, runtime::encode_reflection(output.reflection));
  put_messages(out, output.messages);
}

// Reads fields in order; any read past the end, or a length over its bound, fails the bundle.
class Reader {
 public:
  explicit Reader(std::string_view bytes) : bytes_(bytes) {}
  bool has(uint64_t n) const { return n <= bytes_.size() - at_; }
  uint32_t u32() { return get32(bytes_, (at_ += 4) - 4); }
  uint64_t u64() { return get64(bytes_, (at_ += 8) - 8); }
  Hash128 hash() {
    Hash128 h;
    h.low = u64();
    h.high = u64();
    return h;
  }
  // A length-prefixed field (a view of the bytes): nothing when the length is over `limit` or past the end.
  std::optional<std::string_view> field(uint64_t limit) {
    if (!has(8)) return std::nullopt;
    const uint64_t size = u64();
    if (size > limit || !has(size)) return std::nullopt;
    at_ += size;
    return bytes_.substr(at_ - size, size);
  }
  bool done() const { return at_ == bytes_.size(); }

 private:
  std::string_view bytes_;
  size_t at_ = 0;
};

}  // namespace

std::string encode_shard_bundle(const ShardBundle& bundle) {
  std::vector<const JobOutput*> outputs;
  for (const JobOutput& output : bundle.outputs) outputs.push_back(&output);
  return encode_shard_bundle(bundle, outputs);
}

std::string encode_shard_bundle(const ShardBundle& bundle, const std::vector<const JobOutput*>& outputs) {
  size_t size = kHeaderSize + bundle.sources.size() * (kSourceFixedSize + 256);
  for (const JobOutput* output : outputs) {
    size += kOutputFixedSize + 4096;
    for (const auto& [target, blob] : output->blobs) size += kBlobFixedSize + blob.stored.size();
  }
  std::string out;
  out.reserve(size);
  out.append(kBundleMagic, 8);
  put32(out, kBundleFormat);
  put32(out, bundle.index);
  put32(out, bundle.count);
  put64(out, bundle.source_count);
  put32(out, static_cast<uint32_t>(outputs.size()));
  put32(out, static_cast<uint32_t>(bundle.sources.size()));
  for (const JobOutput* output : outputs) put_output(out, *output);
  for (const ShardBundle::Source& s : bundle.sources) {
    put32(out, s.source);
    put64(out, s.identity);
    put_hash(out, s.key);
    put_hash(out, s.module);
    put32(out, s.output);
    put_messages(out, s.messages);
  }
  return out;
}

Result<ShardBundle> decode_shard_bundle(std::string_view bytes, unsigned threads) {
  if (bytes.size() < kHeaderSize || std::memcmp(bytes.data(), kBundleMagic, 8) != 0) return failure("not a kiln shard bundle");
  Reader in(bytes.substr(8));
  if (const uint32_t format = in.u32(); format != kBundleFormat)
    return failure("shard bundle format " + std::to_string(format) + ", kiln reads " + std::to_string(kBundleFormat));
  ShardBundle bundle;
  bundle.index = in.u32();
  bundle.count = in.u32();
  bundle.source_count = in.u64();
  const uint32_t outputs = in.u32(), sources = in.u32();
  if (bundle.count == 0 || bundle.index >= bundle.count) return failure("shard bundle of share " + std::to_string(bundle.index) + " of " + std::to_string(bundle.count));
  // Each output and source takes at least its fixed fields: counts the bytes cannot hold are refused before anything
  // is reserved.
  if (!in.has(uint64_t{outputs} * kOutputFixedSize + uint64_t{sources} * kSourceFixedSize)) return failure("shard bundle cut short");
  // The outputs' fields, in order (views of the bytes); their blobs are checked and copied out below, on every thread.
  struct EncodedBlob {
    PackedBlob fields;  // stored left empty
    std::string_view stored;
  };
  struct EncodedOutput {
    std::vector<std::pair<Target, EncodedBlob>> blobs;
    bool full_legalization = false;
    std::string_view spirv, reflection, messages;
  };
  std::vector<EncodedOutput> encoded(outputs);
  for (EncodedOutput& output : encoded) {
    if (!in.has(4)) return failure("shard bundle cut short");
    const uint32_t blobs = in.u32();
    if (blobs == 0 || blobs > static_cast<uint32_t>(kTargetCount)) return failure("a shard bundle's output is not a good result");
    for (uint32_t b = 0; b < blobs; ++b) {
      if (!in.has(kBlobFixedSize)) return failure("shard bundle cut short");
      const uint32_t target = in.u32();
      EncodedBlob blob;
      blob.fields.raw_size = in.u64();
      blob.fields.checksum = in.u64();
      blob.fields.key = in.hash();
      auto stored = in.field(kMaxBlobBytes);
      if (target >= static_cast<uint32_t>(kTargetCount) || !stored || stored->size() > blob.fields.raw_size ||
          blob.fields.raw_size > kMaxBlobBytes || (!output.blobs.empty() && output.blobs.back().first >= static_cast<Target>(target)))
        return failure("a shard bundle's blob is cut short, over its size limit, or of no target, or not in order");
      blob.stored = *stored;
      output.blobs.emplace_back(static_cast<Target>(target), blob);
    }
    if (!in.has(4)) return failure("shard bundle cut short");
    const uint32_t flags = in.u32();
    if (flags > 1) return failure("a shard bundle's output has flags kiln does not write");
    output.full_legalization = flags == 1;
    auto spirv = in.field(kMaxBlobBytes);
    auto reflection = spirv ? in.field(kMaxMessagesBytes) : std::nullopt;
    auto messages = reflection ? in.field(kMaxMessagesBytes) : std::nullopt;
    if (!messages) return failure("shard bundle cut short, or an output's field over its size limit");
    output.spirv = *spirv;
    output.reflection = *reflection;
    output.messages = *messages;
  }
  bundle.sources.resize(sources);
  for (ShardBundle::Source& s : bundle.sources) {
    if (!in.has(kSourceFixedSize - 8)) return failure("shard bundle cut short");
    s.source = in.u32();
    s.identity = in.u64();
    s.key = in.hash();
    s.module = in.hash();
    s.output = in.u32();
    if (s.source >= bundle.source_count || s.output >= outputs) return failure("a shard bundle's source names what it does not hold");
    auto messages = in.field(kMaxMessagesBytes);
    if (!messages) return failure("shard bundle cut short, or messages over their size limit");
    auto decoded = decode_messages(*messages);
    if (!decoded) return failure("a shard bundle's messages do not decode");
    s.messages = std::move(*decoded);
  }
  if (!in.done()) return failure("shard bundle has bytes after its last source");
  // The outputs, on every thread: decoded, then every blob unpacked to its size and checksum and hashed to its key.
  bundle.outputs.resize(outputs);
  std::vector<std::string> problems(outputs);
  // Outputs are dealt to the threads in contiguous runs: each thread's scratch buffer serves all of its blobs.
  const size_t runs = std::min<size_t>(outputs, std::max(1u, threads));
  parallel_for(runs, static_cast<unsigned>(runs), [&](size_t run) {
    BlobScratch scratch;
    for (size_t o = run * outputs / runs; o < (run + 1) * outputs / runs; ++o) {
      try {
        const EncodedOutput& in_bundle = encoded[o];
        JobOutput output;
        output.ok = true;
        output.full_legalization = in_bundle.full_legalization;
        output.spirv = spirv_from_bytes(in_bundle.spirv);
        output.reflection = runtime::decode_reflection(in_bundle.reflection);
        auto messages = decode_messages(in_bundle.messages);
        if (!messages) {
          problems[o] = "a shard bundle's output's messages do not decode";
          continue;
        }
        output.messages = std::move(*messages);
        for (const auto& [target, encoded_blob] : in_bundle.blobs) {
          PackedBlob& blob = output.blobs[target] = encoded_blob.fields;
          blob.stored.assign(encoded_blob.stored);
          if (!blob_verifies(blob, scratch))
            problems[o] = "a shard bundle's blob does not unpack to its size, checksum and hash";
        }
        bundle.outputs[o] = std::move(output);
      } catch (const std::exception&) {
        problems[o] = "a shard bundle's output does not decode";
      }
    }
  });
  for (const std::string& problem : problems)
    if (!problem.empty()) return failure(problem);
  return bundle;
}

}  // namespace kiln
