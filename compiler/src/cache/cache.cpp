#include "cache/cache.hpp"

#include <cstring>

#include "common/files.hpp"

namespace kiln {
namespace {

constexpr char kMagic[8] = {'K', 'I', 'L', 'N', 'C', 'A', 'C', 'H'};
// 2: entries are results or aliases (a stage source's key naming its front-end module's entry).
constexpr uint32_t kCacheFormat = 2;
constexpr size_t kHeaderSize = 8 + 4 + 4 + 16 + 8 + 8;
enum EntryKind : uint32_t { kResult = 0, kAlias = 1 };

void put64(std::string& out, uint64_t v) {
  for (int i = 0; i < 8; ++i) out.push_back(static_cast<char>(v >> (8 * i)));
}
uint64_t get64(std::string_view in, size_t at) {
  uint64_t v = 0;
  for (int i = 0; i < 8; ++i) v |= static_cast<uint64_t>(static_cast<unsigned char>(in[at + i])) << (8 * i);
  return v;
}

}  // namespace

Cache::Cache(std::filesystem::path directory) : directory_(std::move(directory)) {}

std::filesystem::path Cache::entry_path(const Hash128& key) const {
  std::string hex = key.hex();
  return directory_ / hex.substr(0, 2) / hex.substr(2);
}

std::optional<Cache::Entry> Cache::read(const Hash128& key, bool& rejected) const {
  rejected = false;
  auto bytes = read_binary_file(entry_path(key));
  if (!bytes) return std::nullopt;
  rejected = true;
  if (bytes->size() < kHeaderSize || std::memcmp(bytes->data(), kMagic, 8) != 0) return std::nullopt;
  uint32_t format = 0, kind = 0;
  std::memcpy(&format, bytes->data() + 8, 4);
  std::memcpy(&kind, bytes->data() + 12, 4);
  if (format != kCacheFormat || (kind != kResult && kind != kAlias)) return std::nullopt;
  if (get64(*bytes, 16) != key.low || get64(*bytes, 24) != key.high) return std::nullopt;
  uint64_t size = get64(*bytes, 32);
  uint64_t checksum = get64(*bytes, 40);
  if (size != bytes->size() - kHeaderSize) return std::nullopt;
  std::string_view payload(bytes->data() + kHeaderSize, size);
  if (hash64(payload) != checksum) return std::nullopt;
  Entry entry;
  if (kind == kAlias) {
    if (payload.size() < 16) return std::nullopt;
    entry.alias = Hash128{get64(payload, 0), get64(payload, 8)};
    payload.remove_prefix(16);
  }
  try {
    entry.output = decode_output(std::vector<uint8_t>(payload.begin(), payload.end()));
  } catch (const std::exception&) {
    return std::nullopt;
  }
  if (!entry.output.ok) return std::nullopt;
  rejected = false;
  return entry;
}

std::optional<JobOutput> Cache::load(const Hash128& key, bool& rejected, std::optional<Hash128>* target_key) const {
  if (target_key) target_key->reset();
  std::optional<Entry> entry = read(key, rejected);
  if (!entry || !entry->alias) return entry ? std::optional<JobOutput>(std::move(entry->output)) : std::nullopt;
  std::optional<Entry> target = read(*entry->alias, rejected);
  if (!target || target->alias) {
    rejected = rejected || target.has_value();  // an alias to an alias is not something kiln writes
    return std::nullopt;
  }
  if (target_key) *target_key = entry->alias;
  JobOutput output = std::move(target->output);
  std::vector<FrontendMessage>& front = entry->output.messages;
  output.messages.insert(output.messages.begin(), front.begin(), front.end());
  return output;
}

bool Cache::write(const Hash128& key, uint32_t kind, std::string_view prefix, const JobOutput& output) const {
  std::vector<uint8_t> encoded = encode_output(output);
  std::string payload(prefix);
  payload.append(reinterpret_cast<const char*>(encoded.data()), encoded.size());
  std::string bytes(kMagic, 8);
  uint32_t format = kCacheFormat;
  bytes.append(reinterpret_cast<const char*>(&format), 4);
  bytes.append(reinterpret_cast<const char*>(&kind), 4);
  put64(bytes, key.low);
  put64(bytes, key.high);
  put64(bytes, payload.size());
  put64(bytes, hash64(payload));
  bytes += payload;
  std::filesystem::path path = entry_path(key);
  std::error_code ec;
  std::filesystem::create_directories(path.parent_path(), ec);
  return write_file_atomic(path, bytes).empty();
}

bool Cache::store(const Hash128& key, const JobOutput& output) const {
  if (!output.ok) return false;
  return write(key, kResult, {}, output);
}

bool Cache::store_alias(const Hash128& key, const Hash128& target, const std::vector<FrontendMessage>& messages) const {
  JobOutput front;
  front.ok = true;
  front.messages = messages;
  std::string prefix;
  put64(prefix, target.low);
  put64(prefix, target.high);
  return write(key, kAlias, prefix, front);
}

}  // namespace kiln
