#include "cache/cache.hpp"

#include <cstring>

#include "common/files.hpp"

namespace kiln {
namespace {

constexpr char kMagic[8] = {'K', 'I', 'L', 'N', 'C', 'A', 'C', 'H'};
constexpr uint32_t kCacheFormat = 1;
constexpr size_t kHeaderSize = 8 + 4 + 4 + 16 + 8 + 8;

void put64(std::string& out, uint64_t v) {
  for (int i = 0; i < 8; ++i) out.push_back(static_cast<char>(v >> (8 * i)));
}
uint64_t get64(const std::string& in, size_t at) {
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

std::optional<JobOutput> Cache::load(const Hash128& key, bool& rejected) const {
  rejected = false;
  auto bytes = read_binary_file(entry_path(key));
  if (!bytes) return std::nullopt;
  rejected = true;
  if (bytes->size() < kHeaderSize || std::memcmp(bytes->data(), kMagic, 8) != 0) return std::nullopt;
  uint32_t format = 0;
  std::memcpy(&format, bytes->data() + 8, 4);
  if (format != kCacheFormat) return std::nullopt;
  if (get64(*bytes, 16) != key.low || get64(*bytes, 24) != key.high) return std::nullopt;
  uint64_t size = get64(*bytes, 32);
  uint64_t checksum = get64(*bytes, 40);
  if (size != bytes->size() - kHeaderSize) return std::nullopt;
  std::string_view payload(bytes->data() + kHeaderSize, size);
  if (hash64(payload) != checksum) return std::nullopt;
  try {
    JobOutput output = decode_output(std::vector<uint8_t>(payload.begin(), payload.end()));
    if (!output.ok) return std::nullopt;
    rejected = false;
    return output;
  } catch (const std::exception&) {
    return std::nullopt;
  }
}

bool Cache::store(const Hash128& key, const JobOutput& output) const {
  if (!output.ok) return false;
  std::vector<uint8_t> payload = encode_output(output);
  std::string bytes(kMagic, 8);
  uint32_t format = kCacheFormat;
  bytes.append(reinterpret_cast<const char*>(&format), 4);
  bytes.append(4, '\0');
  put64(bytes, key.low);
  put64(bytes, key.high);
  put64(bytes, payload.size());
  put64(bytes, hash64(std::string_view(reinterpret_cast<const char*>(payload.data()), payload.size())));
  bytes.append(reinterpret_cast<const char*>(payload.data()), payload.size());
  std::filesystem::path path = entry_path(key);
  std::error_code ec;
  std::filesystem::create_directories(path.parent_path(), ec);
  return write_file_atomic(path, bytes).empty();
}

}  // namespace kiln
