// SPDX-License-Identifier: Apache-2.0
// The remote cache tier, under the local cache: the Bazel HTTP cache protocol (GET/PUT/HEAD on
// {base}[/instance]/ac/<sha256> and {base}[/instance]/cas/<sha256>), as bazel-remote and any WebDAV server
// (nginx `dav_methods PUT`) speak it. See docs/remote-cache.md.
//
// Entries mirror the local cache's two levels. A module's result is an AC record (the outputs' reflection and
// messages, and for each output the SHA-256 and size of its packed blob) plus one CAS blob per output; a stage
// source's key holds an alias record naming its module's result. Keys are SHA-256 over a domain tag, the format
// version, the namespace and the same fields as the local keys.
//
// Nothing from the server is trusted until checked: a record's magic, format, kind, key echo, size and SHA-256,
// then every blob's size and SHA-256, and that the blob unpacks to the size and checksum the record gives. A
// failed check is a miss (K1705). Failures never fail a build unless `required`: each kind is one warning per
// build, and a connection failure, or three errors in a row, switches the remote off for the rest of the build.
#pragma once

#include <array>
#include <atomic>
#include <condition_variable>
#include <deque>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <set>
#include <string>
#include <thread>
#include <vector>

#include "common/hash.hpp"
#include "kiln/build.hpp"
#include "kiln/diagnostics.hpp"
#include "remote/http_client.hpp"
#include "common/compile_result.hpp"
#include "kiln/result.hpp"

namespace kiln {

struct RemoteKey {
  std::array<unsigned char, 32> bytes{};
  std::string hex() const;
  friend bool operator==(const RemoteKey&, const RemoteKey&) = default;
  friend auto operator<=>(const RemoteKey&, const RemoteKey&) = default;
};

// SHA-256 of the bytes.
RemoteKey sha256(std::string_view bytes);
RemoteKey sha256(const std::vector<std::string_view>& parts);  // of the parts joined

// Streams fields into a SHA-256 key the way Hasher streams them into a local key (each field length-prefixed),
// so a remote key covers exactly what the local key it shadows covers.
class RemoteKeyHasher {
 public:
  RemoteKeyHasher();
  ~RemoteKeyHasher();
  RemoteKeyHasher(const RemoteKeyHasher&) = delete;
  RemoteKeyHasher& operator=(const RemoteKeyHasher&) = delete;
  RemoteKeyHasher& add(std::string_view field);
  RemoteKeyHasher& add(uint64_t value);
  RemoteKey finish();

 private:
  void* context_;  // EVP_MD_CTX*
};

// What a source key's alias and its module's result gave: the build uses it as a local cache hit would.
struct RemoteFetched {
  Hash128 module;                                // the module's local key (for the local cache and the funnel)
  std::vector<FrontendMessage> front_messages;   // the alias's
  JobOutput module_output;                       // the result, its blobs verified
};

class RemoteLookups;

class RemoteCache {
 public:
  // Nothing when `options.url` is empty. When the settings cannot be used (a bad URL, an unreadable token file, a
  // token over plain HTTP to another host) reports K1707 and returns a remote that is already switched off.
  static std::unique_ptr<RemoteCache> open(const RemoteCacheOptions& options, DiagnosticSink& sink);
  ~RemoteCache();

  // A key hasher started with the domain tag, the format version, the namespace and `kind` ("source", "module").
  void start_key(RemoteKeyHasher& hasher, std::string_view kind) const;

  // One slot per key: the entry, or nothing (a miss, or a failure, which is counted and warned about).
  std::vector<std::optional<RemoteFetched>> fetch(const std::vector<RemoteKey>& source_keys);

  struct ModuleUpload {
    RemoteKey key;
    const JobOutput* output;
  };
  struct AliasUpload {
    RemoteKey key;
    size_t module;  // index into the modules given with it
    Hash128 module_local;
    const std::vector<FrontendMessage>* messages;
  };
  // Blobs first, then each module's record, then the aliases of the modules now on the server, so a reader
  // never finds a record whose blobs are missing. A module whose record and blobs are already there is not sent
  // again; one whose entry this build's fetch found missing or damaged, or whose blobs are gone, is put again whole.
  void upload(const std::vector<ModuleUpload>& modules, const std::vector<AliasUpload>& aliases);

  // The pack-level entry: the finished pack (archive and manifest, as CAS blobs) under a key of the build's
  // inputs, so an unchanged checkout another machine built costs a few requests. fetch_pack writes the pack
  // into `directory` (archive first, then the manifest's rename, as a build does) only after PackReader opened
  // it whole from a scratch directory beside it; returns the archive's file name.
  std::optional<std::string> fetch_pack(const RemoteKey& key, const std::filesystem::path& directory,
                                        const std::string& pack_name);
  // upload_pack takes the two files' bytes as the build wrote them.
  void upload_pack(const RemoteKey& key, const std::string& archive_file, const std::vector<std::string_view>& archive,
                   std::string_view manifest);

  // Sharded builds (--shard I/N): a shard's bundle of results (driver/shard_bundle.hpp) as a CAS blob, then its
  // record (the bundle's SHA-256 and size) under the shard's key, so a reader never finds a record whose bundle is
  // missing; and the record of how many shards the build of these inputs was split into. False when not uploaded.
  bool upload_shard(const RemoteKey& key, std::string_view bundle);
  bool upload_shard_count(const RemoteKey& key, uint32_t count);
  // The shard count a sharded build of these inputs recorded, when there is one.
  std::optional<uint32_t> fetch_shard_count(const RemoteKey& key);
  // Whether each record is on the server (HEAD requests, in parallel): has every other shard finished?
  std::vector<bool> have_records(const std::vector<RemoteKey>& keys);
  // Each shard's bundle, its record checked and its bytes matching the record's size and SHA-256, handed to `use`
  // with its index in `keys`, in that order; never for a shard whose record or bundle is missing or damaged (the
  // merge looks its sources up one by one). Bundles are downloaded in parallel in batches of at most
  // kShardBatchBytes as their records announce them (a larger bundle alone), and each batch is handed over and
  // freed before the next is fetched: what a merge holds is bounded by the batch, not by what the remote announces.
  static constexpr uint64_t kShardBatchBytes = uint64_t{512} << 20;
  void fetch_shards(const std::vector<RemoteKey>& keys, const std::function<void(size_t, std::string&&)>& use);

  // An entry whose bytes arrived whole but whose content the caller found wrong (a shard bundle): K1705, as for the
  // remote's own checks. `where` names the object.
  void entry_rejected(const std::string& why, const std::string& where);
  // A merge's count: the shards' bundles it used, and the stage sources they gave.
  void count_shard_bundles(size_t bundles, size_t sources);

  // Reports each kind of failure seen since the last call (once per build), errors when `required`.
  void report_problems(DiagnosticSink& sink);
  RemoteReport report() const;
  bool usable() const { return !switched_off_; }

 private:
  friend class RemoteLookups;
  explicit RemoteCache(const RemoteCacheOptions& options);
  std::optional<RemoteFetched> fetch_counted(const RemoteKey& source_key);
  Result<void> configure();  // the error says why the settings cannot be used
  std::unique_ptr<HttpClient> take_client();
  void give_back(std::unique_ptr<HttpClient> client);
  std::string url(std::string_view kind, const RemoteKey& key) const;
  // Counts a request's outcome: true when it was answered (any status). Failures are recorded by kind.
  bool answered(const HttpResult& result, const std::string& what);
  void problem(DiagId id, const std::string& message, const std::string& note = {});
  void success();
  std::optional<RemoteFetched> fetch_one(HttpClient& client, const RemoteKey& key);
  // A record's checked payload; nothing when the server has no such record (404); an error (counted and recorded as a
  // problem already) when the request failed or the record failed its checks.
  Result<std::optional<std::string>> get_record(HttpClient& client, const RemoteKey& key, uint32_t kind);
  bool upload_module(HttpClient& client, const ModuleUpload& module);
  bool put(HttpClient& client, const std::string& target, std::string_view body);
  bool put(HttpClient& client, const std::string& target, const std::vector<std::string_view>& body);  // the parts joined
  bool make_collection(HttpClient& client, const std::string& collection, int levels);
  std::optional<std::string> get_blob(HttpClient& client, const RemoteKey& digest, uint64_t size);

  RemoteCacheOptions options_;
  std::string base_;     // the URL with the instance, no trailing slash
  std::string display_;  // the URL as diagnostics show it: no user name or password
  HttpSettings http_;
  std::atomic<bool> switched_off_{false};
  mutable std::mutex mutex_;
  std::vector<std::unique_ptr<HttpClient>> idle_;
  RemoteReport report_;
  unsigned consecutive_errors_ = 0;
  // Per diagnostic: the messages seen (ordered, so the one reported does not depend on thread timing).
  std::map<DiagId, std::vector<std::pair<std::string, std::string>>> problems_;  // message, note
  std::map<DiagId, bool> reported_;
  std::set<RemoteKey> damaged_;  // module keys whose entries fetch found missing or damaged
};

// Lookups that run beside the build: the scheduler submits each stage source's key as soon as it knows it, and a
// miss can start its compile while other lookups go on. `parallel_transfers` threads (started at the first submit)
// share the remote's connections; results are collected on the caller's thread, in the order they finished (the
// build's output does not depend on that order). `ready_fd()` (an eventfd) is readable when results wait, so a poll
// loop wakes on it (ExternalWork in workers/job_runner.hpp).
class RemoteLookups {
 public:
  explicit RemoteLookups(RemoteCache& remote);
  ~RemoteLookups();  // waits for the lookups in flight; those not started are dropped
  RemoteLookups(const RemoteLookups&) = delete;
  RemoteLookups& operator=(const RemoteLookups&) = delete;

  void submit(size_t tag, const RemoteKey& key);
  // The lookups finished since the last call: (tag, the entry or nothing).
  std::vector<std::pair<size_t, std::optional<RemoteFetched>>> take();
  // Blocks until a result waits or nothing is outstanding.
  void wait();
  size_t outstanding() const;  // submitted and not yet taken
  int ready_fd() const { return ready_fd_; }

 private:
  void work();

  RemoteCache& remote_;
  int ready_fd_ = -1;
  mutable std::mutex mutex_;
  std::condition_variable queued_, finished_;
  std::deque<std::pair<size_t, RemoteKey>> queue_;
  std::vector<std::pair<size_t, std::optional<RemoteFetched>>> done_;
  size_t outstanding_ = 0;
  bool stopping_ = false;
  std::vector<std::thread> threads_;
};

}  // namespace kiln
