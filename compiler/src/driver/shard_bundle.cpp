#include "driver/shard_bundle.hpp"

#include <atomic>
#include <cstring>
#include <exception>
#include <optional>

#include "common/blob.hpp"
#include "common/bytes.hpp"
#include "common/parallel.hpp"
#include "kiln/pack_format.hpp"
#include "kiln/stage_target.hpp"

namespace kiln {
namespace {

constexpr char kBundleMagic[8] = {'K', 'I', 'L', 'N', 'S', 'H', 'R', 'D'};
constexpr uint32_t kBundleFormat = 1;
constexpr size_t kHeaderSize = 8 + 4 + 4 + 4 + 8 + 4 + 4;
constexpr size_t kSourceFixedSize = 4 + 8 + 16 + 16 + 4 + 8;
// An output holds at most a blob per target; a front end's messages are a few KiB. These bound what one field of a
// hostile bundle makes kiln decode.
constexpr uint64_t kMaxMessagesBytes = uint64_t{16} << 20;
constexpr uint64_t kMaxOutputBytes = uint64_t{8} * kMaxBlobBytes;

void put_hash(std::string& out, const Hash128& hash) {
  put64(out, hash.low);
  put64(out, hash.high);
}

void put_cbor(std::string& out, const std::vector<uint8_t>& encoded) {
  put64(out, encoded.size());
  out.append(reinterpret_cast<const char*>(encoded.data()), encoded.size());
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
  std::string out(kBundleMagic, 8);
  put32(out, kBundleFormat);
  put32(out, bundle.index);
  put32(out, bundle.count);
  put64(out, bundle.source_count);
  put32(out, static_cast<uint32_t>(bundle.outputs.size()));
  put32(out, static_cast<uint32_t>(bundle.sources.size()));
  for (const JobOutput& output : bundle.outputs) put_cbor(out, encode_output(output));
  for (const ShardBundle::Source& s : bundle.sources) {
    put32(out, s.source);
    put64(out, s.identity);
    put_hash(out, s.key);
    put_hash(out, s.module);
    put32(out, s.output);
    JobOutput front;
    front.ok = true;
    front.messages = s.messages;
    put_cbor(out, encode_output(front));
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
  // Each output and source takes at least 8 bytes: counts the bytes cannot hold are refused before anything is reserved.
  if (!in.has(uint64_t{outputs} * 8 + uint64_t{sources} * kSourceFixedSize)) return failure("shard bundle cut short");
  std::vector<std::string_view> encoded(outputs);
  for (auto& field : encoded) {
    auto read = in.field(kMaxOutputBytes);
    if (!read) return failure("shard bundle cut short, or an output over its size limit");
    field = std::move(*read);
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
    try {
      JobOutput front = decode_output(*messages);
      if (!front.ok || !front.blobs.empty()) return failure("a shard bundle's messages do not decode");
      s.messages = std::move(front.messages);
    } catch (const std::exception&) {
      return failure("a shard bundle's messages do not decode");
    }
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
        JobOutput output = decode_output(encoded[o]);
        if (!output.ok || output.blobs.empty() || output.blobs.size() > static_cast<size_t>(kTargetCount)) {
          problems[o] = "a shard bundle's output is not a good result";
          continue;
        }
        for (const auto& [target, blob] : output.blobs)
          if (blob.raw_size > kMaxBlobBytes || !blob_verifies(blob, scratch))
            problems[o] = "a shard bundle's blob does not unpack to its size, checksum and hash";
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
