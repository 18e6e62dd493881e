// SPDX-License-Identifier: Apache-2.0
// The remote cache tier against a real nginx (WebDAV PUT) on loopback: two clients sharing one server, and each
// fault a build must survive with the same pack and one warning (an error with --remote-required).
// No test depends on timing: a timeout is a server that never answers, and the outcome is asserted, not the time.
#include <gtest/gtest.h>
#include <fcntl.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <map>

#include <nlohmann/json.hpp>

#include "kiln/build.hpp"
#include "remote/remote_cache.hpp"
#include "mutating_server.hpp"
#include "servers.hpp"
#include "test_support.hpp"

namespace kiln {
namespace {

// Two keyword groups: 2 vertex and 4 fragment stage sources, 5 modules.
void write_library(const testing::TempDir& dir, const std::string& root = ".") {
  dir.write(root + "/lib/Shadows.hlsl", "#pragma once\nfloat ShadowTerm(float x) { return saturate(x * 0.5); }\n");
  dir.write(root + "/lib/Fog.hlsl", "#pragma once\nfloat FogTerm(float x) { return exp2(-x); }\n");
  dir.write(root + "/S.hlsl",
            "#pragma multi_compile _ SHADOWS\n#pragma multi_compile_fragment _ FOG\n"
            "#include \"Shadows.hlsl\"\n#ifdef FOG\n#include \"Fog.hlsl\"\n#endif\n"
            "float4 V(float4 p : POSITION) : SV_Position { return p; }\n"
            "float4 F(float4 p : SV_Position) : SV_Target {\n  float c = 1.0;\n"
            "#ifdef SHADOWS\n  c *= ShadowTerm(p.x);\n#endif\n#ifdef FOG\n  c *= FogTerm(p.y);\n#endif\n"
            "  return float4(c, c, c, 1.0);\n}\n");
  dir.write(root + "/p.pack.json", R"({"name": "p", "include_dirs": ["lib"],
      "passes": [{"name": "P", "source": "S.hlsl", "stages": {"vertex": "V", "fragment": "F"}}]})");
}

void overwrite(const std::filesystem::path& path, const std::string& bytes) {
  std::ofstream(path, std::ios::binary | std::ios::trunc) << bytes;
}

std::string text_of(const DiagnosticSink& sink) {
  std::string text;
  for (const Diagnostic& d : sink.diagnostics()) text += format_diagnostic(d);
  return text;
}

// The pack's two files, as bytes.
std::pair<std::string, std::string> pack_bytes(const std::filesystem::path& out) {
  return {testing::read_file(out / "p.manifest.json"), testing::read_archive(out / "p.manifest.json")};
}

struct Remote : ::testing::Test {
  testing::TempDir dir;
  int builds = 0;
  void SetUp() override { write_library(dir); }

  // A build with its own output and local cache directories: one "machine" each.
  BuildReport build(RemoteCacheOptions remote, DiagnosticSink& sink, const std::function<void()>& on_progress = {}) {
    BuildOptions options;
    options.pack_file = dir / "p.pack.json";
    const std::string name = "build" + std::to_string(builds++);
    options.output_dir = dir / (name + "/out");
    options.cache_dir = dir / (name + "/cache");
    options.jobs = 2;
    options.worker_executable = KILN_WORKER_PATH;
    options.remote = std::move(remote);
    options.shard_index = shard_index;
    options.shard_count = shard_count;
    if (on_progress) options.progress = [&](size_t, size_t, size_t) { on_progress(); };
    if (on_settled) options.progress = [&](size_t done, size_t, size_t) { on_settled(done); };
    last_output = options.output_dir;
    return build_pack(options, sink);
  }
  std::filesystem::path last_output;
  unsigned shard_index = 0, shard_count = 1;

  // The merge of a sharded build (no --shard) reading `url`: it must succeed and say nothing.
  BuildReport quiet_merge(const std::string& url) {
    shard_count = 1;
    DiagnosticSink sink;
    BuildReport merge = build(serial(url), sink);
    EXPECT_TRUE(merge.ok) << text_of(sink);
    EXPECT_EQ(text_of(sink), "");
    return merge;
  }
  std::function<void(size_t settled)> on_settled;  // the build's progress: stage sources settled so far

  std::pair<std::string, std::string> reference() {
    DiagnosticSink sink;
    EXPECT_TRUE(build({}, sink).ok) << text_of(sink);
    return pack_bytes(last_output);
  }

  // One request at a time: which request fails first, and whether the remote is switched off, are then the same
  // in every run, so the warnings' exact text can be asserted.
  static RemoteCacheOptions serial(const std::string& url, bool upload = false) {
    RemoteCacheOptions remote;
    remote.url = url;
    remote.upload = upload;
    remote.parallel_transfers = 1;
    return remote;
  }

  // Fills the server from a build that uploads: 5 results, 6 aliases and the pack-level entry. Unless `keep_pack`,
  // the pack-level entry is then removed from the server, so that the next builds use the per-source entries.
  template <class Server>
  void populate(const Server& server, RemoteCacheOptions remote = {}, bool keep_pack = false) {
    if (remote.url.empty()) remote = serial(server.url(), true);
    remote.upload = true;
    DiagnosticSink sink;
    BuildReport report = build(remote, sink);
    ASSERT_TRUE(report.ok) << text_of(sink);
    ASSERT_EQ(sink.warning_count(), 0) << text_of(sink);
    ASSERT_EQ(report.remote.uploads, 5u + 6u + 1u);
    if (!keep_pack) forget_pack(server);
  }

  // The pack-level record (kind 3) and the two blobs it names (manifest, archive), by their names on disk.
  struct PackEntry {
    std::filesystem::path record, manifest, archive;
  };
  template <class Server>
  static PackEntry pack_entry(const Server& server) {
    for (const auto& record : stored(server, "ac")) {
      const std::string bytes = testing::read_file(record);
      if (bytes.size() < 92 || bytes[12] != 3) continue;
      const size_t name = static_cast<unsigned char>(bytes[88]), at = 92 + name;
      auto blob = [&](size_t offset) {
        RemoteKey key;
        std::copy(bytes.begin() + static_cast<long>(offset), bytes.begin() + static_cast<long>(offset) + 32, key.bytes.begin());
        return server.data() / "cas" / key.hex();
      };
      return {record, blob(at), blob(at + 40)};
    }
    return {};
  }
  // A build of this checkout into `out` (with a local cache of its own) that reads `server`: it fetches the pack.
  template <class Server>
  BuildOptions fetch_options(const Server& server, const std::filesystem::path& out) const {
    BuildOptions options;
    options.pack_file = dir / "p.pack.json";
    options.output_dir = out;
    options.cache_dir = dir / "fetched-cache";
    options.worker_executable = KILN_WORKER_PATH;
    options.remote = serial(server.url());
    return options;
  }
  template <class Server>
  static void forget_pack(const Server& server) {
    PackEntry entry = pack_entry(server);
    ASSERT_FALSE(entry.record.empty());
    for (const auto& file : {entry.record, entry.manifest, entry.archive}) ASSERT_TRUE(std::filesystem::remove(file)) << file;
  }

  // The fault's warning is exactly `expected` (its location is the server's URL) and the pack is the reference's;
  // with --remote-required the same problem is an error and the build fails.
  void expect_survived(RemoteCacheOptions remote, const std::string& expected, DiagId id) {
    const auto wanted = reference();
    DiagnosticSink sink;
    BuildReport report = build(remote, sink);
    EXPECT_TRUE(report.ok) << text_of(sink);
    EXPECT_EQ(text_of(sink), expected);
    EXPECT_TRUE(pack_bytes(last_output) == wanted) << "the pack differs from a build without the remote";
    EXPECT_GE(report.remote.errors, 1u);

    remote.required = true;
    DiagnosticSink strict;
    BuildReport failed = build(remote, strict);
    EXPECT_FALSE(failed.ok);
    // A lookup's fault fails the build before anything is compiled; an upload's comes after the compiles it uploads.
    if (id != DiagId::RemoteUploadRefused) {
      EXPECT_EQ(failed.compiled, 0u) << "--remote-required fails at the first remote error, before compiling";
    }
    bool found = false;
    for (const Diagnostic& d : strict.diagnostics()) found |= d.id == id && d.severity == Severity::Error;
    EXPECT_TRUE(found) << text_of(strict);
    EXPECT_FALSE(std::filesystem::exists(last_output / "p.manifest.json"));
  }

  // Every file nginx stores under data/<kind>/, by name.
  template <class Server>
  static std::vector<std::filesystem::path> stored(const Server& server, const std::string& kind) {
    std::vector<std::filesystem::path> files;
    for (const auto& entry : std::filesystem::directory_iterator(server.data() / kind)) files.push_back(entry.path());
    std::sort(files.begin(), files.end());
    return files;
  }
};

const std::string kNeverFails = "  note: a remote cache problem never fails a build; --remote-required makes it an error\n";
const std::string kSwitchedOff = "  note: the remote cache is off for the rest of this build\n";

TEST_F(Remote, ASecondClientWithItsOwnLocalCacheCompilesNothingAndWritesTheSamePack) {
  testing::WebDav server;
  const auto wanted = reference();
  RemoteCacheOptions remote;
  remote.url = server.url();
  remote.upload = true;
  DiagnosticSink first_sink;
  BuildReport first = build(remote, first_sink);
  ASSERT_TRUE(first.ok) << text_of(first_sink);
  EXPECT_EQ(first.compiled, 6u);
  EXPECT_EQ(first.remote.misses, 6u);
  EXPECT_EQ(first.remote.uploads, 12u);
  EXPECT_EQ(first.remote.errors, 0u);
  EXPECT_EQ(stored(server, "ac").size(), 12u);  // 5 results, 6 aliases, the pack
  EXPECT_TRUE(pack_bytes(last_output) == wanted);
  forget_pack(server);  // the per-source entries, here

  remote.upload = false;
  DiagnosticSink second_sink;
  BuildReport second = build(remote, second_sink);
  ASSERT_TRUE(second.ok) << text_of(second_sink);
  EXPECT_EQ(second.compiled, 0u);
  EXPECT_EQ(second.back_ends, 0u);
  EXPECT_EQ(second.remote.hits, 6u);
  EXPECT_EQ(second.remote.errors, 0u);
  EXPECT_GT(second.remote.bytes_down, 0u);
  EXPECT_EQ(text_of(second_sink), "");
  EXPECT_TRUE(pack_bytes(last_output) == wanted) << "the pack differs from a build that compiled";
  // What came from the remote went into that client's local cache: its next build is all local hits.
  BuildOptions again;
  again.pack_file = dir / "p.pack.json";
  again.output_dir = dir / "again";
  again.cache_dir = dir / "build2/cache";
  again.worker_executable = KILN_WORKER_PATH;
  server.stop();
  DiagnosticSink again_sink;
  BuildReport third = build_pack(again, again_sink);
  ASSERT_TRUE(third.ok);
  EXPECT_EQ(third.cache_hits, 6u);
  EXPECT_TRUE(pack_bytes(dir / "again") == wanted);
}

// The pack-level entry: an unchanged checkout fetches the finished pack in three requests (record, manifest,
// archive), and its next build is up to date.
TEST_F(Remote, AnUnchangedCheckoutFetchesTheFinishedPackInThreeRequests) {
  testing::WebDav server;
  const auto wanted = reference();
  populate(server, {}, true);
  const auto requests = [&] {
    const std::string log = testing::read_file(server.access_log());
    return std::count(log.begin(), log.end(), '\n');
  };
  const auto before = requests();
  const BuildOptions options = fetch_options(server, dir / "fetched");
  DiagnosticSink sink;
  BuildReport report = build_pack(options, sink);
  ASSERT_TRUE(report.ok) << text_of(sink);
  EXPECT_TRUE(report.remote.pack_fetched);
  EXPECT_EQ(report.compiled, 0u);
  EXPECT_EQ(report.workers_started, 0u);
  EXPECT_EQ(requests() - before, 3);
  EXPECT_EQ(text_of(sink), "");
  EXPECT_TRUE(pack_bytes(dir / "fetched") == wanted);
  BuildReport again = build_pack(options, sink);
  EXPECT_TRUE(again.up_to_date);
  EXPECT_EQ(requests() - before, 3);
}

// A build killed while it fetched a pack left its scratch directory (a whole archive) in the output directory
// forever. The next fetch removes the scratch of every process that no longer runs, and only that.
TEST_F(Remote, AFetchRemovesTheScratchOfAKilledFetch) {
  testing::WebDav server;
  populate(server, {}, true);
  const std::filesystem::path out = dir / "fetched";
  const std::filesystem::path dead = out / ".kiln-remote-999999999-aBcDeF", live = out / (".kiln-remote-" + std::to_string(::getpid()) + "-xYz123");
  for (const auto& scratch : {dead, live}) {
    std::filesystem::create_directories(scratch);
    std::ofstream(scratch / "p.0123456789abcdef.kpack") << "half an archive";
  }
  DiagnosticSink sink;
  BuildReport report = build_pack(fetch_options(server, out), sink);
  ASSERT_TRUE(report.ok) << text_of(sink);
  EXPECT_TRUE(report.remote.pack_fetched);
  EXPECT_FALSE(std::filesystem::exists(dead)) << "a dead process's scratch is still there";
  EXPECT_TRUE(std::filesystem::exists(live / "p.0123456789abcdef.kpack")) << "a running process's scratch was removed";
  std::vector<std::string> left;
  for (const auto& entry : std::filesystem::directory_iterator(out))
    if (entry.path().filename().string().starts_with(".kiln-remote-") && entry.path() != live) left.push_back(entry.path());
  EXPECT_TRUE(left.empty()) << left.front();
}

// The remote-response fuzzer: a server answers every request with damaged or resealed bytes (testing::
// MutatingServer; fixed seed, bounded count of builds). Whatever comes back, every build succeeds with the pack of a
// build without the remote, and says so only in warnings: the forged record of 200,000 nested CBOR arrays crashed it.
TEST_F(Remote, MutatedResponsesNeverCrashABuildOrChangeItsPack) {
  testing::WebDav server;
  const auto wanted = reference();
  populate(server, {}, true);  // the pack-level entry stays: its record and blobs are mutated too
  testing::MutatingServer mutating(server.data(), 2026);
  for (int round = 0; round < 24; ++round) {
    RemoteCacheOptions remote = serial(mutating.url());
    remote.operation_timeout = std::chrono::seconds(10);
    DiagnosticSink sink;
    BuildReport report = build(remote, sink);
    ASSERT_TRUE(report.ok) << "round " << round << "\n" << text_of(sink);
    EXPECT_TRUE(pack_bytes(last_output) == wanted) << "round " << round << ": the pack differs";
    for (const Diagnostic& d : sink.diagnostics()) EXPECT_NE(d.severity, Severity::Error) << format_diagnostic(d);
  }
  EXPECT_GE(mutating.answered(), 48u);
  EXPECT_GE(mutating.resealed(), 12u);
}

TEST_F(Remote, ADamagedPackEntryIsAMissAndTheSourcesAreFetchedInstead) {
  testing::WebDav server;
  const auto wanted = reference();
  populate(server, {}, true);
  const PackEntry entry = pack_entry(server);
  std::string bytes = testing::read_file(entry.archive);
  bytes[bytes.size() / 2] ^= 0x10;
  overwrite(entry.archive, bytes);
  DiagnosticSink sink;
  BuildReport report = build(serial(server.url()), sink);
  ASSERT_TRUE(report.ok) << text_of(sink);
  EXPECT_FALSE(report.remote.pack_fetched);
  EXPECT_EQ(report.remote.hits, 6u);
  EXPECT_EQ(report.compiled, 0u);
  EXPECT_EQ(text_of(sink), server.url() + ": warning[K1705]: a remote cache entry failed verification: a blob's SHA-256 "
                                          "does not match its name\n  note: at cas/" + entry.archive.filename().string() +
                               "\n" + kNeverFails);
  EXPECT_TRUE(pack_bytes(last_output) == wanted);
}

// Faults of the server or of the settings: nginx configured to produce them, a socket thread (FaultServer), or no
// server at all. Each runs once, against nginx (remote.Faults.*); the rest of the suite runs against Apache too.
struct Faults : Remote {};

// Blobs first, then the record that names them, then the aliases: a blob the server refuses keeps its record (and
// the aliases to it) off the server, and everything else is uploaded.
TEST_F(Faults, ARecordIsNeverWrittenBeforeItsBlobs) {
  std::string refused;
  {
    testing::Nginx first;  // only to learn the name of one blob
    populate(first);
    refused = stored(first, "cas").front().filename().string();
  }
  testing::Nginx server({"      location = /cas/" + refused + " { if ($request_method = PUT) { return 507; } }"});
  DiagnosticSink sink;
  BuildReport report = build(serial(server.url(), true), sink);
  EXPECT_TRUE(report.ok) << text_of(sink);
  EXPECT_TRUE(sink.contains(DiagId::RemoteUploadRefused));
  EXPECT_FALSE(std::filesystem::exists(server.data() / "cas" / refused));
  EXPECT_GT(report.remote.uploads, 0u);
  // Every record names only objects that are there: a result its blobs, an alias its result.
  auto hex_at = [](const std::string& bytes, size_t at) {
    RemoteKey key;
    std::copy(bytes.begin() + static_cast<long>(at), bytes.begin() + static_cast<long>(at) + 32, key.bytes.begin());
    return key.hex();
  };
  for (const auto& record : stored(server, "ac")) {
    const std::string bytes = testing::read_file(record);
    if (bytes[12] == 1) {
      const size_t count = static_cast<unsigned char>(bytes[88]);
      for (size_t i = 0; i < count; ++i)
        EXPECT_TRUE(std::filesystem::exists(server.data() / "cas" / hex_at(bytes, 88 + 4 + i * 44 + 4))) << record;
    } else if (bytes[12] == 2) {
      EXPECT_TRUE(std::filesystem::exists(server.data() / "ac" / hex_at(bytes, 88))) << record;
    }
  }
}

// bazel-remote refuses chunked uploads; curl would also wait for "100 Continue" on large bodies. nginx refuses both
// here, so a populated server shows every PUT had a Content-Length and no Expect header.
TEST_F(Faults, UploadsSendAContentLengthNeverChunkedAndNoExpect) {
  testing::Nginx server({"      if ($http_transfer_encoding) { return 411; }\n      if ($http_expect) { return 417; }"});
  populate(server);
}

// A redirect is not followed (it could lead from https:// to http://, or anywhere): it is an error status.
TEST_F(Faults, ARedirectIsNotFollowed) {
  testing::Nginx server({"      return 302 http://127.0.0.1:9/elsewhere;"});
  expect_survived(serial(server.url()),
                  server.url() + ": warning[K1703]: the remote cache answered a download with HTTP 302\n" + kSwitchedOff +
                      kNeverFails,
                  DiagId::RemoteServerError);
}

// --shard I/N: each shard compiles a disjoint share of the misses (by key, so the share does not depend on the
// order of the variant list) and writes no pack; the merge build compiles nothing and writes the same pack.
// Shards deal out the stage sources before preprocessing: alone, each preprocesses and compiles only its share, and
// the shares add up to every stage source once.
TEST_F(Remote, ShardsPreprocessAndCompileOnlyTheirShare) {
  shard_count = 3;
  size_t compiled = 0;
  for (shard_index = 0; shard_index < shard_count; ++shard_index) {
    testing::WebDav own;  // each with a server of its own: nothing found, no other shard's bundle
    DiagnosticSink sink;
    BuildReport report = build(serial(own.url(), true), sink);
    ASSERT_TRUE(report.ok) << text_of(sink);
    EXPECT_EQ(report.compiled, 2u);       // 6 stage sources, 2 per share
    EXPECT_EQ(report.shard_skipped, 4u);  // the others' are not even preprocessed
    EXPECT_EQ(report.remote.misses, 2u);  // and not looked up
    EXPECT_FALSE(report.shard_assembled);
    EXPECT_FALSE(std::filesystem::exists(last_output / "p.manifest.json"));
    compiled += report.compiled;
  }
  EXPECT_EQ(compiled, 6u);
}

// Side by side on one server: the shard that finds every other shard's bundle there writes the pack one machine
// writes, from one bundle per shard, and uploads it: the merge job then fetches the finished pack.
TEST_F(Remote, TheShardThatFinishesLastAssemblesThePackFromOneBundlePerShard) {
  const auto wanted = reference();
  testing::WebDav server;
  shard_count = 3;
  size_t compiled = 0;
  for (shard_index = 0; shard_index < shard_count; ++shard_index) {
    DiagnosticSink sink;
    BuildReport report = build(serial(server.url(), true), sink);
    ASSERT_TRUE(report.ok) << text_of(sink);
    EXPECT_EQ(text_of(sink), "");
    compiled += report.compiled;
    const bool last = shard_index + 1 == shard_count;
    EXPECT_EQ(report.shard_assembled, last);
    EXPECT_EQ(std::filesystem::exists(last_output / "p.manifest.json"), last);
    if (last) {
      EXPECT_TRUE(pack_bytes(last_output) == wanted);
      EXPECT_EQ(report.remote.shard_bundles, 3u);
      EXPECT_EQ(report.remote.shard_sources, 6u);
    }
  }
  EXPECT_EQ(compiled, 6u);
  shard_count = 1;
  DiagnosticSink sink;
  BuildReport merge = build(serial(server.url()), sink);
  ASSERT_TRUE(merge.ok) << text_of(sink);
  EXPECT_TRUE(merge.remote.pack_fetched);
  EXPECT_TRUE(pack_bytes(last_output) == wanted);
}

// The merge job without the finished pack (the last shard's upload of it failed, or the server showed it a stale
// view): one bundle per shard and nothing else, no per-source lookup, nothing preprocessed or compiled, the pack of
// one machine.
TEST_F(Remote, TheMergeFetchesOneBundlePerShardAndLooksUpNothingElse) {
  const auto wanted = reference();
  testing::WebDav server;
  shard_count = 3;
  for (shard_index = 0; shard_index < shard_count; ++shard_index) {
    DiagnosticSink sink;
    ASSERT_TRUE(build(serial(server.url(), true), sink).ok) << text_of(sink);
  }
  forget_pack(server);
  const BuildReport merge = quiet_merge(server.url());
  EXPECT_EQ(merge.remote.shard_bundles, 3u);
  EXPECT_EQ(merge.remote.shard_sources, 6u);
  EXPECT_EQ(merge.remote.hits + merge.remote.misses, 0u);
  EXPECT_EQ(merge.compiled, 0u);
  EXPECT_EQ(merge.workers_started, 0u);  // not even preprocessed
  EXPECT_TRUE(pack_bytes(last_output) == wanted);
}

// More shards than stage sources: the shares past the sixth are empty, their shards compile nothing and upload an
// empty bundle, and the pack is still one machine's.
TEST_F(Remote, ShardsWithEmptySharesStillTakePart) {
  const auto wanted = reference();
  testing::WebDav server;
  shard_count = 8;
  size_t compiled = 0, assembled = 0;
  for (shard_index = 0; shard_index < shard_count; ++shard_index) {
    DiagnosticSink sink;
    BuildReport report = build(serial(server.url(), true), sink);
    ASSERT_TRUE(report.ok) << text_of(sink);
    EXPECT_EQ(report.compiled, shard_index < 6 ? 1u : 0u);
    compiled += report.compiled;
    assembled += report.shard_assembled;
  }
  EXPECT_EQ(compiled, 6u);
  EXPECT_EQ(assembled, 1u);
  EXPECT_TRUE(pack_bytes(last_output) == wanted);
  forget_pack(server);
  const BuildReport merge = quiet_merge(server.url());
  EXPECT_EQ(merge.remote.shard_bundles, 6u);  // the two empty shares' bundles are not fetched
  EXPECT_EQ(merge.compiled, 0u);
  EXPECT_TRUE(pack_bytes(last_output) == wanted);
}

// A shard that never ran: the merge takes the other bundles and compiles the missing share (its per-source entries
// are not there either); the pack is the same.
TEST_F(Remote, AMissingShardLeavesItsShareToTheMerge) {
  const auto wanted = reference();
  testing::WebDav server;
  shard_count = 3;
  for (shard_index = 0; shard_index < 2; ++shard_index) {
    DiagnosticSink sink;
    BuildReport report = build(serial(server.url(), true), sink);
    ASSERT_TRUE(report.ok) << text_of(sink);
    EXPECT_FALSE(report.shard_assembled);
  }
  const BuildReport merge = quiet_merge(server.url());
  EXPECT_EQ(merge.remote.shard_bundles, 2u);
  EXPECT_EQ(merge.remote.shard_sources, 4u);
  EXPECT_EQ(merge.remote.misses, 2u);
  EXPECT_EQ(merge.compiled, 2u);
  EXPECT_TRUE(pack_bytes(last_output) == wanted);
}

TEST_F(Remote, ReadOnlyUnlessUploadIsAsked) {
  testing::WebDav server;
  DiagnosticSink sink;
  BuildReport report = build(serial(server.url()), sink);
  ASSERT_TRUE(report.ok) << text_of(sink);
  EXPECT_EQ(report.remote.uploads, 0u);
  EXPECT_FALSE(std::filesystem::exists(server.data() / "ac"));
}

TEST_F(Remote, NamespacesAndInstancesKeepCachesApartOnOneServer) {
  testing::WebDav server;
  RemoteCacheOptions main = serial(server.url(), true);
  main.key_namespace = "main";
  populate(server, main);
  RemoteCacheOptions pull_request = serial(server.url());
  pull_request.key_namespace = "pr";
  DiagnosticSink sink;
  EXPECT_EQ(build(pull_request, sink).remote.hits, 0u);
  main.upload = false;
  EXPECT_EQ(build(main, sink).remote.hits, 6u);
  RemoteCacheOptions instance = main;
  instance.instance = "team/shaders";
  EXPECT_EQ(build(instance, sink).remote.hits, 0u);
  instance.upload = true;
  build(instance, sink);
  EXPECT_TRUE(std::filesystem::exists(server.data() / "team/shaders/ac"));
  EXPECT_EQ(sink.warning_count(), 0) << text_of(sink);
}

TEST_F(Faults, ServerDownIsOneWarningAndTheRemoteIsSwitchedOff) {
  const std::string url = "http://127.0.0.1:" + std::to_string(testing::free_port());
  expect_survived(serial(url), url + ": warning[K1701]: cannot reach the remote cache: Couldn't connect to server\n" +
                                   kSwitchedOff + kNeverFails,
                  DiagId::RemoteUnreachable);
}

// The server goes away after the pack-level lookup, the shard count's and the first stage source's: connections are
// refused from then on. (Which lookups were asked before the remote was switched off depends on the preprocessing's order: only the
// outcome is asserted.)
TEST_F(Faults, ConnectionRefusedMidBuildIsOneWarning) {
  testing::FaultServer server(testing::FaultServer::Mode::GoesAway, 3);
  const auto wanted = reference();
  DiagnosticSink sink;
  BuildReport report = build(serial(server.url(), true), sink);
  EXPECT_TRUE(report.ok) << text_of(sink);
  EXPECT_EQ(report.remote.hits, 0u);
  EXPECT_GE(report.remote.misses, 2u);
  EXPECT_TRUE(report.remote.switched_off);
  EXPECT_EQ(report.compiled, 6u);
  EXPECT_EQ(text_of(sink), server.url() + ": warning[K1701]: cannot reach the remote cache: Couldn't connect to server\n" +
                               kSwitchedOff + kNeverFails);
  EXPECT_TRUE(pack_bytes(last_output) == wanted);
}

TEST_F(Faults, ServerErrorsAreMissesWithOneWarning) {
  testing::Nginx server({"      return 500;"});
  expect_survived(serial(server.url()),
                  server.url() + ": warning[K1703]: the remote cache answered a download with HTTP 500\n" + kSwitchedOff +
                      kNeverFails,
                  DiagId::RemoteServerError);
}

TEST_F(Faults, TooManyRequestsIsAServerErrorToo) {
  testing::Nginx server({"      return 429;"});
  expect_survived(serial(server.url()),
                  server.url() + ": warning[K1703]: the remote cache answered a download with HTTP 429\n" + kSwitchedOff +
                      kNeverFails,
                  DiagId::RemoteServerError);
}

// Anonymous reads, authenticated writes (basic auth with an htpasswd file made by openssl passwd -apr1).
struct AuthenticatedPut : Remote {
  testing::TempDir secrets;
  std::filesystem::path htpasswd() {
    testing::RunResult hashed = testing::run({"/usr/bin/openssl", "passwd", "-apr1", "s3cret-password"}, secrets.path());
    secrets.write("netrc", "machine 127.0.0.1 login builder password s3cret-password\n");
    return secrets.write("htpasswd", "builder:" + hashed.out);
  }
};

TEST_F(AuthenticatedPut, WithoutCredentialsAnUploadIs401AndABuildStillSucceeds) {
  testing::WebDav server({htpasswd()});
  expect_survived(serial(server.url(), true),
                  server.url() + ": warning[K1706]: the remote cache refused an upload with HTTP 401\n" + kSwitchedOff +
                      kNeverFails,
                  DiagId::RemoteUploadRefused);
}

TEST_F(AuthenticatedPut, NetrcCredentialsUploadAndAnonymousClientsRead) {
  testing::WebDav server({htpasswd()});
  RemoteCacheOptions writer = serial(server.url(), true);
  writer.netrc_file = secrets / "netrc";
  populate(server, writer);
  DiagnosticSink sink;
  BuildReport reader = build(serial(server.url()), sink);
  EXPECT_EQ(reader.remote.hits, 6u);
  EXPECT_EQ(reader.compiled, 0u);
  EXPECT_EQ(text_of(sink), "");
}

TEST_F(Faults, ForbiddenUploadIsOneWarning) {
  testing::Nginx server({"      limit_except GET HEAD { deny all; }"});
  expect_survived(serial(server.url(), true),
                  server.url() + ": warning[K1706]: the remote cache refused an upload with HTTP 403\n" + kSwitchedOff +
                      kNeverFails,
                  DiagId::RemoteUploadRefused);
}

TEST_F(Faults, DiskFullOnTheServerIsOneWarning) {
  testing::Nginx server({"      if ($request_method = PUT) { return 507; }"});
  expect_survived(serial(server.url(), true),
                  server.url() + ": warning[K1706]: the remote cache refused an upload with HTTP 507\n" + kSwitchedOff +
                      kNeverFails,
                  DiagId::RemoteUploadRefused);
}

// A bearer token is checked by nginx on writes; kiln never prints it.
TEST_F(Faults, ABearerTokenAuthorizesUploadsAndIsNeverPrinted) {
  testing::Nginx server({"      set $refused \"\";\n"
                         "      if ($request_method = PUT) { set $refused \"put\"; }\n"
                         "      if ($http_authorization = \"Bearer t0ken-abc\") { set $refused \"\"; }\n"
                         "      if ($refused) { return 401; }"});
  RemoteCacheOptions wrong = serial(server.url(), true);
  wrong.bearer_token = "wr0ng-t0ken";
  DiagnosticSink sink;
  EXPECT_TRUE(build(wrong, sink).ok);
  EXPECT_EQ(text_of(sink), server.url() + ": warning[K1706]: the remote cache refused an upload with HTTP 401\n" + kSwitchedOff +
                      kNeverFails);
  EXPECT_EQ(text_of(sink).find("wr0ng"), std::string::npos);

  testing::TempDir secrets;
  RemoteCacheOptions right = serial(server.url(), true);
  right.token_file = secrets.write("token", "t0ken-abc\n");
  populate(server, right);
}

TEST_F(Faults, ATokenIsNeverSentOverPlainHttpToAnotherHost) {
  RemoteCacheOptions remote = serial("http://user:hunter2@cache.example.invalid:8080/base/");
  remote.bearer_token = "t0ken-abc";
  const auto wanted = reference();
  DiagnosticSink sink;
  BuildReport report = build(remote, sink);
  EXPECT_TRUE(report.ok);
  EXPECT_EQ(text_of(sink), "http://cache.example.invalid:8080/base: warning[K1707]: refusing to send the remote cache token "
                           "over plain HTTP to 'cache.example.invalid': use https://\n"
                           "  note: the build goes on without the remote cache\n" + kNeverFails);
  EXPECT_TRUE(pack_bytes(last_output) == wanted);
}

TEST_F(Faults, AnUnreadableTokenFileIsAConfigurationWarning) {
  RemoteCacheOptions remote = serial("https://127.0.0.1:9");
  remote.token_file = dir / "no-such-token";
  DiagnosticSink sink;
  EXPECT_TRUE(build(remote, sink).ok);
  EXPECT_EQ(text_of(sink), "https://127.0.0.1:9: warning[K1707]: the token file '" + (dir / "no-such-token").string() +
                               "' cannot be read (or is over 4 KiB)\n"
                               "  note: the build goes on without the remote cache\n" + kNeverFails);
}

// When the build needs the remote (an upload asked for, or --remote-required), settings that cannot be used fail it
// at once: a CI job meant to warm the cache does not run cold for minutes and upload nothing.
TEST_F(Faults, SettingsThatCannotUploadFailAnUploadingBuildBeforeItCompiles) {
  for (const bool required : {false, true}) {
    SCOPED_TRACE(required ? "required" : "upload");
    RemoteCacheOptions remote = serial("https://127.0.0.1:9", /*upload=*/!required);
    remote.required = required;
    remote.token_file = dir / "no-such-token";
    DiagnosticSink sink;
    BuildReport report = build(remote, sink);
    EXPECT_FALSE(report.ok);
    EXPECT_EQ(report.compiled, 0u);  // nothing was compiled before the error
    const std::string text = text_of(sink);
    EXPECT_TRUE(text.starts_with("https://127.0.0.1:9: error[K1707]: the token file '" + (dir / "no-such-token").string() +
                                 "' cannot be read (or is over 4 KiB)\n  note: the build stops before compiling anything\n"))
        << text;
    EXPECT_EQ(text.find("never fails a build"), std::string::npos) << text;
  }
}

// A CR/LF in KILN_REMOTE_TOKEN would end the Authorization header and add headers of the token's choosing; the
// variable is held to the token file's rule (one printable token) and nothing is sent.
TEST_F(Remote, ATokenWithALineBreakIsRefusedBeforeAnyRequest) {
  testing::WebDav server;
  RemoteCacheOptions remote = serial(server.url());
  remote.bearer_token = "t0ken\r\nX-Injected: yes";
  DiagnosticSink sink;
  EXPECT_TRUE(build(remote, sink).ok);
  EXPECT_EQ(text_of(sink), server.url() + ": warning[K1707]: the remote cache token (KILN_REMOTE_TOKEN) is not one token: it "
                                          "holds a space, a line break or another character outside printable ASCII\n"
                                          "  note: the build goes on without the remote cache\n" + kNeverFails);
  EXPECT_EQ(testing::read_file(server.access_log()), "") << "a request was sent";
}

TEST_F(Faults, AResponseThatNeverComesTimesOut) {
  testing::FaultServer silent(testing::FaultServer::Mode::Silent);
  RemoteCacheOptions remote = serial(silent.url());
  remote.operation_timeout = std::chrono::milliseconds(100);
  expect_survived(remote,
                  silent.url() + ": warning[K1702]: no answer from the remote cache within the request timeout (100 ms)\n" +
                      kSwitchedOff + kNeverFails,
                  DiagId::RemoteTimeout);
}

// A server whose accept queue is full drops the connection attempt: no connection within the connect timeout
// switches the remote off at once (every other request would wait as long).
TEST_F(Faults, AConnectionThatNeverCompletesTimesOutAndSwitchesTheRemoteOff) {
  testing::FaultServer full(testing::FaultServer::Mode::Backlogged);
  RemoteCacheOptions remote = serial(full.url());
  remote.connect_timeout = std::chrono::milliseconds(100);
  expect_survived(remote,
                  full.url() + ": warning[K1702]: could not connect to the remote cache within the connect timeout (100 ms)\n" +
                      kSwitchedOff + kNeverFails,
                  DiagId::RemoteTimeout);
}

// A server that answers a byte at a time (4 bytes a second) never reaches the request timeout (30 s by default):
// the low-speed limit cuts it off, and the remote is off for the rest of the build.
TEST_F(Faults, ADripFeedingServerIsCutOffByTheLowSpeedLimit) {
  testing::FaultServer drip(testing::FaultServer::Mode::Drip);
  expect_survived(serial(drip.url()),
                  drip.url() + ": warning[K1702]: the remote cache sent less than 1024 bytes a second for 4 s: the "
                               "transfer was cut off\n" + kSwitchedOff + kNeverFails,
                  DiagId::RemoteTimeout);
}

// Lookups overlap compiling: a remote miss starts its compile while later lookups still wait for their answers. The
// server answers the pack-level lookup, the shard count's and the first stage source's at once (404) and holds the
// next request (a 404
// whose body comes slowly, over the low-speed limit) until the build has settled a stage source, which here only a
// compile can do, or until its 60 s deadline. A build that waited for every answer before compiling would wait
// for that deadline (or its own request timeout, an error).
TEST_F(Faults, AMissCompilesWhileOtherLookupsWaitForTheirAnswers) {
  testing::FaultServer server(testing::FaultServer::Mode::Gate, /*answered_at_once=*/3);
  RemoteCacheOptions remote = serial(server.url());
  remote.operation_timeout = std::chrono::seconds(300);
  const auto wanted = reference();
  on_settled = [&](size_t settled) {
    if (settled > 0) server.open();
  };
  DiagnosticSink sink;
  BuildReport report = build(remote, sink);
  on_settled = {};
  EXPECT_TRUE(report.ok) << text_of(sink);
  EXPECT_TRUE(server.held_a_request());
  EXPECT_FALSE(server.gate_timed_out()) << "nothing was compiled while a lookup waited for its answer";
  EXPECT_EQ(text_of(sink), "");
  EXPECT_EQ(report.remote.errors, 0u);
  EXPECT_EQ(report.remote.misses, 6u);
  EXPECT_EQ(report.compiled, 6u);
  EXPECT_TRUE(pack_bytes(last_output) == wanted);
}

// 429 and 5xx are tried twice more (after 100 and 200 ms): a server that is unavailable for two requests in a row
// costs nothing; for three, the request fails (one warning) and the rest of the build goes on with the remote.
TEST_F(Faults, AnUnavailableServerIsTriedTwiceMoreBeforeARequestFails) {
  const auto wanted = reference();
  {
    testing::FaultServer server(testing::FaultServer::Mode::Unavailable, 2);
    DiagnosticSink sink;
    BuildReport report = build(serial(server.url()), sink);
    EXPECT_TRUE(report.ok) << text_of(sink);
    EXPECT_EQ(text_of(sink), "");
    EXPECT_EQ(report.remote.errors, 0u);
    EXPECT_EQ(report.remote.misses, 6u);
    EXPECT_EQ(server.accepted(), 2 + 1 + 1 + 6)
        << "the pack-level lookup three times, the shard count's, then one request per stage source";
    EXPECT_TRUE(pack_bytes(last_output) == wanted);
  }
  testing::FaultServer server(testing::FaultServer::Mode::Unavailable, 3);
  DiagnosticSink sink;
  BuildReport report = build(serial(server.url()), sink);
  EXPECT_TRUE(report.ok) << text_of(sink);
  EXPECT_EQ(text_of(sink), server.url() + ": warning[K1703]: the remote cache answered a download with HTTP 503\n" + kNeverFails);
  EXPECT_EQ(report.remote.errors, 1u);
  EXPECT_FALSE(report.remote.switched_off);
  EXPECT_EQ(server.accepted(), 3 + 1 + 6);
  EXPECT_TRUE(pack_bytes(last_output) == wanted);
}

TEST_F(Faults, ABodyCutShortOfItsLengthIsAMiss) {
  testing::FaultServer truncated(testing::FaultServer::Mode::Truncated);
  expect_survived(serial(truncated.url()),
                  truncated.url() + ": warning[K1704]: a download from the remote cache was cut short: Transferred a "
                                    "partial file\n" + kSwitchedOff + kNeverFails,
                  DiagId::RemoteTransferCut);
  // Each cut request was tried 3 times (1 + 2 retries), on a new connection each (the server closes them): 3 requests
  // before three errors in a row switched the remote off, then 1 under --remote-required, which stops at the first.
  EXPECT_EQ(truncated.accepted(), (3 + 1) * 3);
}

// Entries damaged on the server's disk: each is a miss, compiled again, and named.
struct Tampered : Remote {
  testing::WebDav server;
  void SetUp() override {
    Remote::SetUp();
    populate(server);
  }
  std::string rejected(const std::string& why, const std::string& where) {
    return server.url() + ": warning[K1705]: a remote cache entry failed verification: " + why + "\n  note: at " + where +
           "\n" + kNeverFails;
  }
};

// A merge reads the shards' bundles as it reads any remote entry: a bundle that is damaged, forged or of another share
// is a warning (K1705), and its share comes from the shards' per-source entries instead; the pack is one machine's.
struct TamperedShards : Remote {
  testing::WebDav server;
  std::pair<std::string, std::string> wanted;
  void SetUp() override {
    Remote::SetUp();
    wanted = reference();
    shard_count = 3;
    for (shard_index = 0; shard_index < shard_count; ++shard_index) {
      DiagnosticSink sink;
      ASSERT_TRUE(build(serial(server.url(), true), sink).ok) << text_of(sink);
    }
    shard_count = 1;
    forget_pack(server);
  }
  // The record (kind 4) of shard `index`, and the bundle it names.
  struct ShardEntry {
    std::filesystem::path record, bundle;
  };
  ShardEntry shard_entry(unsigned index) {
    for (const auto& record : stored(server, "ac")) {
      const std::string bytes = testing::read_file(record);
      if (bytes.size() != 88 + 40 || bytes[12] != 4) continue;
      RemoteKey digest;
      std::copy(bytes.begin() + 88, bytes.begin() + 120, digest.bytes.begin());
      const std::filesystem::path bundle = server.data() / "cas" / digest.hex();
      char head[16] = {};  // the bundle's magic, format and share index (not the whole bundle: some are forged 1.5 GiB)
      std::ifstream(bundle, std::ios::binary).read(head, sizeof head);
      if (static_cast<unsigned char>(head[12]) == index) return {record, bundle};
    }
    ADD_FAILURE() << "no record of shard " << index;
    return {};
  }
  // Puts `bytes` as the bundle of shard `index`'s record, resealed: it passes every check of the transport. Returns
  // the warning a merge gives for it, saying `why`.
  std::string forge(unsigned index, const std::string& bytes, const std::string& why) {
    const RemoteKey digest = sha256(bytes);
    overwrite(server.data() / "cas" / digest.hex(), bytes);
    const ShardEntry entry = name_bundle(index, digest, bytes.size());
    return server.url() + ": warning[K1705]: a remote cache entry failed verification: " + why + "\n  note: at the bundle of shard " +
           std::to_string(index) + "/3, ac/" + entry.record.filename().string() + "\n" + kNeverFails;
  }
  // Makes shard `index`'s record name the bundle `digest` of `size` bytes, resealed.
  ShardEntry name_bundle(unsigned index, const RemoteKey& digest, uint64_t size) {
    const ShardEntry entry = shard_entry(index);
    std::string record = testing::read_file(entry.record);
    record.replace(88, 32, reinterpret_cast<const char*>(digest.bytes.data()), 32);
    for (int i = 0; i < 8; ++i) record[120 + i] = static_cast<char>(size >> (8 * i));
    const RemoteKey resealed = sha256(std::string_view(record).substr(88));
    record.replace(56, 32, reinterpret_cast<const char*>(resealed.bytes.data()), 32);
    overwrite(entry.record, record);
    return entry;
  }
  // The merge survives with `expected` said once, takes the other two bundles and compiles nothing.
  void expect_merged(const std::string& expected) {
    DiagnosticSink sink;
    BuildReport merge = build(serial(server.url()), sink);
    ASSERT_TRUE(merge.ok) << text_of(sink);
    EXPECT_EQ(text_of(sink), expected);
    EXPECT_EQ(merge.remote.shard_bundles, 2u);
    EXPECT_EQ(merge.remote.shard_sources, 4u);
    EXPECT_EQ(merge.remote.hits, 2u);  // the damaged share's per-source entries
    EXPECT_EQ(merge.compiled, 0u);
    EXPECT_TRUE(pack_bytes(last_output) == wanted);
  }
};

TEST_F(TamperedShards, ABundleWhoseBytesNoLongerMatchItsDigest) {
  const ShardEntry entry = shard_entry(1);
  std::string bytes = testing::read_file(entry.bundle);
  bytes[bytes.size() / 2] ^= 0x20;
  overwrite(entry.bundle, bytes);
  DiagnosticSink sink;
  BuildReport merge = build(serial(server.url()), sink);
  ASSERT_TRUE(merge.ok) << text_of(sink);
  EXPECT_EQ(text_of(sink), server.url() + ": warning[K1705]: a remote cache entry failed verification: a blob's SHA-256 does "
                                          "not match its name\n  note: at cas/" + entry.bundle.filename().string() + "\n" + kNeverFails);
  EXPECT_EQ(merge.remote.shard_bundles, 2u);
  EXPECT_EQ(merge.compiled, 0u);
  EXPECT_TRUE(pack_bytes(last_output) == wanted);
}

TEST_F(TamperedShards, AResealedBundleCutShort) {
  const std::string bytes = testing::read_file(shard_entry(1).bundle);
  expect_merged(forge(1, bytes.substr(0, bytes.size() - 7), "shard bundle cut short, or messages over their size limit"));
}

TEST_F(TamperedShards, AResealedBundleWithABlobThatDoesNotUnpackToItsHash) {
  std::string bytes = testing::read_file(shard_entry(2).bundle);
  // The first byte of the first output's first blob: after the header (36 bytes), the blob count, and the blob's
  // target, size, checksum, key and length (48 bytes).
  bytes[36 + 4 + 44] ^= 0x01;
  forge(2, bytes, "");
  DiagnosticSink sink;
  BuildReport merge = build(serial(server.url()), sink);
  ASSERT_TRUE(merge.ok) << text_of(sink);
  EXPECT_NE(text_of(sink).find("warning[K1705]: a remote cache entry failed verification: a shard bundle's"), std::string::npos)
      << text_of(sink);
  EXPECT_EQ(merge.remote.shard_bundles, 2u);  // the third fetched whole, then refused
  EXPECT_EQ(merge.remote.shard_sources, 4u);
  EXPECT_EQ(merge.compiled, 0u);
  EXPECT_TRUE(pack_bytes(last_output) == wanted);
}

// Records that name bundles of 3 GiB each: their sum is over what one pack's archive may be, so nothing is downloaded
// and every share comes from the per-source entries.
TEST_F(TamperedShards, RecordsWhoseBundlesTogetherAreOverAnArchivesLimit) {
  for (unsigned index : {0u, 1u}) {
    std::string record = testing::read_file(shard_entry(index).record);
    RemoteKey digest;
    std::copy(record.begin() + 88, record.begin() + 120, digest.bytes.begin());
    name_bundle(index, digest, uint64_t{3} << 30);
  }
  DiagnosticSink sink;
  BuildReport merge = build(serial(server.url()), sink);
  ASSERT_TRUE(merge.ok) << text_of(sink);
  EXPECT_NE(text_of(sink).find("warning[K1705]: a remote cache entry failed verification: the shards' bundles would be"),
            std::string::npos)
      << text_of(sink);
  EXPECT_EQ(merge.remote.shard_bundles, 0u);
  EXPECT_EQ(merge.remote.hits, 6u);
  EXPECT_EQ(merge.compiled, 0u);
  EXPECT_LT(merge.remote.bytes_down, uint64_t{1} << 20);
  EXPECT_TRUE(pack_bytes(last_output) == wanted);
}

// Records that announce two bundles of 1.5 GiB each (together within an archive's limit), served whole by the
// server (sparse files), to a merge whose address space cannot hold one: each is a fallback to the per-source
// entries, never a failed build. The merge runs in a child process under the lowered limit (RLIMIT_AS, 1 GiB over
// what the child already maps) so that the limit is this test's alone; no other thread runs when it forks.
TEST_F(TamperedShards, BundlesTooLargeToHoldInMemoryAreAFallback) {
#if defined(__SANITIZE_ADDRESS__)
  GTEST_SKIP() << "ASan reserves terabytes of shadow memory: no address-space limit there";
#endif
  const uint64_t size = uint64_t{3} << 29;
  for (unsigned index : {0u, 1u}) {
    const RemoteKey digest = sha256("a forged bundle of shard " + std::to_string(index));
    const std::filesystem::path bundle = server.data() / "cas" / digest.hex();
    overwrite(bundle, "");
    std::filesystem::resize_file(bundle, size);
    name_bundle(index, digest, size);
  }
  const std::filesystem::path out = dir / ("build" + std::to_string(builds) + "/out");
  const pid_t child = ::fork();
  ASSERT_GE(child, 0);
  if (child == 0) {
    ::alarm(120);
    uint64_t mapped_kb = 0;
    std::ifstream status("/proc/self/status");
    for (std::string line; std::getline(status, line);)
      if (line.starts_with("VmSize:")) mapped_kb = std::strtoull(line.c_str() + 7, nullptr, 10);
    const rlimit limit{(mapped_kb << 10) + (uint64_t{1} << 30), RLIM_INFINITY};
    if (mapped_kb == 0 || ::setrlimit(RLIMIT_AS, &limit) != 0) std::_Exit(3);
    DiagnosticSink sink;
    const BuildReport merge = build(serial(server.url()), sink);
    const std::string text = text_of(sink);
    std::fprintf(stderr, "%s", text.c_str());
    const bool fell_back = merge.ok && merge.compiled == 0 && merge.remote.shard_bundles == 1 && merge.remote.hits == 4 &&
                           text.find("warning[K1705]: a remote cache download was larger than this process could hold "
                                     "in memory") != std::string::npos;
    std::_Exit(fell_back ? 0 : 1);
  }
  int status = 0;
  ASSERT_EQ(::waitpid(child, &status, 0), child);
  ASSERT_TRUE(WIFEXITED(status)) << "the merge was killed by signal " << WTERMSIG(status);
  EXPECT_EQ(WEXITSTATUS(status), 0) << "the merge failed, or did not fall back (its messages are above)";
  EXPECT_TRUE(pack_bytes(out) == wanted);
}

// Shard 0's bundle under shard 1's record: well-formed, but its sources are another share's.
TEST_F(TamperedShards, TheBundleOfAnotherShare) {
  expect_merged(forge(1, testing::read_file(shard_entry(0).bundle), "a shard bundle is of another share or another plan"));
}

// The bundle of a plan with another stage source in the same place (an edited shader's keywords): each source's
// identity is checked against this plan's.
TEST_F(TamperedShards, ABundleWhoseSourcesAreNotThisPlansSources) {
  std::string bytes = testing::read_file(shard_entry(1).bundle);
  // The first source's identity: after the header and the outputs (docs/remote-cache.md, format 2), 4 bytes in.
  auto number = [&](size_t at, int size) {
    uint64_t value = 0;
    for (int i = 0; i < size; ++i) value |= uint64_t{static_cast<unsigned char>(bytes.at(at + i))} << (8 * i);
    return value;
  };
  size_t at = 36;
  for (uint64_t o = 0, outputs = number(28, 4); o < outputs; ++o) {
    const uint64_t blobs = number(at, 4);
    at += 4;
    for (uint64_t b = 0; b < blobs; ++b) at += 4 + 8 + 8 + 16 + 8 + number(at + 36, 8);  // target .. key, length, bytes
    at += 4;                                                                        // flags
    for (int field = 0; field < 3; ++field) at += 8 + number(at, 8);                // SPIR-V, reflection, messages
  }
  bytes.at(at + 4) ^= 0x01;
  expect_merged(forge(1, bytes, "a shard bundle's sources are not its share of this plan"));
}

TEST_F(Tampered, ABlobWhoseBytesNoLongerMatchItsDigest) {
  const std::filesystem::path blob = stored(server, "cas").front();
  std::string bytes = testing::read_file(blob);
  bytes[bytes.size() / 2] ^= 0x20;
  overwrite(blob, bytes);
  expect_survived(serial(server.url()),
                  rejected("a blob's SHA-256 does not match its name", "cas/" + blob.filename().string()),
                  DiagId::RemoteEntryRejected);
}

TEST_F(Tampered, ABlobReplacedByAnotherBlob) {
  const auto blobs = stored(server, "cas");
  const std::filesystem::path victim = blobs.front(), other = blobs.back();
  const std::string replacement = testing::read_file(other);
  const bool same_size = replacement.size() == std::filesystem::file_size(victim);
  overwrite(victim, replacement);
  expect_survived(serial(server.url()),
                  rejected(same_size ? "a blob's SHA-256 does not match its name" : "a blob has the wrong size",
                           "cas/" + victim.filename().string()),
                  DiagId::RemoteEntryRejected);
}

// Eviction (examples/remote_cache/evict.sh) or an upload cut short leaves entries in part: an alias whose result
// record is gone (what a build sees when eviction runs between its two requests for an entry), a record whose blob
// is gone. Each is a plain miss, compiled again: no warning, and no error even with --remote-required.
TEST_F(Tampered, AnEntryFoundInPartIsAMissNeverAnError) {
  std::filesystem::path result_record;
  for (const auto& record : stored(server, "ac")) {
    if (testing::read_file(record)[12] == 1) {  // kind 1: a module's result
      result_record = record;
      break;
    }
  }
  ASSERT_FALSE(result_record.empty());
  ASSERT_TRUE(std::filesystem::remove(result_record));
  ASSERT_TRUE(std::filesystem::remove(stored(server, "cas").front()));
  const auto wanted = reference();
  RemoteCacheOptions remote = serial(server.url());
  remote.required = true;
  DiagnosticSink sink;
  BuildReport report = build(remote, sink);
  EXPECT_TRUE(report.ok) << text_of(sink);
  EXPECT_EQ(text_of(sink), "");
  EXPECT_EQ(report.remote.errors, 0u);
  EXPECT_GE(report.remote.incomplete, 1u);
  EXPECT_EQ(report.remote.misses, report.remote.incomplete) << "every alias is there: each miss is an entry found in part";
  EXPECT_EQ(report.remote.hits + report.remote.misses, 6u);
  EXPECT_GE(report.compiled, 1u);
  EXPECT_TRUE(pack_bytes(last_output) == wanted);
}

TEST_F(Tampered, ARecordWithACorruptByte) {
  const std::filesystem::path record = stored(server, "ac").front();
  std::string bytes = testing::read_file(record);
  bytes.back() ^= 0x01;
  overwrite(record, bytes);
  expect_survived(serial(server.url()), rejected("record checksum does not match", "ac/" + record.filename().string()),
                  DiagId::RemoteEntryRejected);
}

// A whole, well-formed record served under another key (a server mixing up names): the key echo refuses it.
TEST_F(Tampered, ARecordServedUnderAnotherKey) {
  std::map<char, std::vector<std::filesystem::path>> by_kind;
  for (const auto& record : stored(server, "ac")) by_kind[testing::read_file(record)[12]].push_back(record);
  const std::vector<std::filesystem::path>& aliases = by_kind[2];
  ASSERT_GE(aliases.size(), 2u);
  overwrite(aliases[1], testing::read_file(aliases[0]));
  expect_survived(serial(server.url()), rejected("record of another key", "ac/" + aliases[1].filename().string()),
                  DiagId::RemoteEntryRejected);
}

// A record resealed by someone who can write the server (its checksum is right) that names another blob: the blob
// is what its digest says, but not what the record says it is.
TEST_F(Tampered, AResealedRecordWhoseBlobDigestNamesAnotherBlob) {
  std::filesystem::path result;
  std::string bytes;
  for (const auto& record : stored(server, "ac")) {
    bytes = testing::read_file(record);
    if (bytes.size() > 92 && bytes[12] == 1) {  // a result record (kind 1) with its blob list
      result = record;
      break;
    }
  }
  ASSERT_FALSE(result.empty());
  // Header: magic 8, format 4, kind 4, key 32, payload size 8, payload SHA-256 32; payload: count 4, then per blob
  // target 4, digest 32, size 8. The first blob's digest and size become those of a blob of another entry.
  constexpr size_t header = 88, first_digest = header + 4 + 4, first_size = first_digest + 32;
  const std::string first = std::string(bytes, first_digest, 32);
  std::filesystem::path other;
  for (const auto& blob : stored(server, "cas")) {
    const RemoteKey name = sha256(testing::read_file(blob));
    if (std::string(reinterpret_cast<const char*>(name.bytes.data()), 32) != first &&
        std::filesystem::file_size(blob) > 64) {
      other = blob;
      break;
    }
  }
  ASSERT_FALSE(other.empty());
  const std::string other_bytes = testing::read_file(other);
  const RemoteKey digest = sha256(other_bytes);
  bytes.replace(first_digest, 32, reinterpret_cast<const char*>(digest.bytes.data()), 32);
  for (int i = 0; i < 8; ++i) bytes[first_size + i] = static_cast<char>(uint64_t{other_bytes.size()} >> (8 * i));
  const RemoteKey resealed = sha256(std::string_view(bytes).substr(header));
  bytes.replace(56, 32, reinterpret_cast<const char*>(resealed.bytes.data()), 32);
  overwrite(result, bytes);
  expect_survived(serial(server.url()),
                  rejected("a blob does not unpack to the record's size, checksum and hash", "cas/" + other.filename().string()),
                  DiagId::RemoteEntryRejected);
}

// Repair: an uploading build puts again what its lookups found missing or damaged, and the blobs of a record whose
// blobs are gone, so the next reader compiles nothing (it used to skip any module whose record was there).
TEST_F(Tampered, AnUploadingBuildRepairsDamagedAndMissingBlobsForTheNextReader) {
  const auto blobs = stored(server, "cas");
  ASSERT_GE(blobs.size(), 2u);
  std::string bytes = testing::read_file(blobs.front());
  bytes[bytes.size() / 2] ^= 0x20;
  overwrite(blobs.front(), bytes);
  ASSERT_TRUE(std::filesystem::remove(blobs.back()));
  DiagnosticSink uploader_sink;
  BuildReport uploader = build(serial(server.url(), true), uploader_sink);
  ASSERT_TRUE(uploader.ok) << text_of(uploader_sink);
  EXPECT_GE(uploader.compiled, 1u);
  EXPECT_GE(uploader.remote.repaired, 1u);
  EXPECT_EQ(sha256(testing::read_file(blobs.front())).hex(), blobs.front().filename().string()) << "the damaged blob is whole again";
  EXPECT_TRUE(std::filesystem::exists(blobs.back())) << "the missing blob is back";
  DiagnosticSink reader_sink;
  BuildReport reader = build(serial(server.url()), reader_sink);
  EXPECT_TRUE(reader.ok) << text_of(reader_sink);
  EXPECT_EQ(text_of(reader_sink), "");
  EXPECT_EQ(reader.compiled, 0u);
  EXPECT_EQ(reader.remote.misses, 0u);
}

// A record this build never read (every alias is gone, so no lookup reaches it) whose blob is gone: the upload's HEAD
// requests find the hole and fill it.
TEST_F(Tampered, AnUploadingBuildPutsBackTheBlobsOfARecordItDidNotRead) {
  for (const auto& record : stored(server, "ac")) {
    if (testing::read_file(record)[12] == 2) {  // kind 2: an alias
      ASSERT_TRUE(std::filesystem::remove(record));
    }
  }
  const std::filesystem::path blob = stored(server, "cas").front();
  ASSERT_TRUE(std::filesystem::remove(blob));
  DiagnosticSink uploader_sink;
  BuildReport uploader = build(serial(server.url(), true), uploader_sink);
  ASSERT_TRUE(uploader.ok) << text_of(uploader_sink);
  EXPECT_EQ(text_of(uploader_sink), "");
  EXPECT_EQ(uploader.remote.repaired, 1u);
  EXPECT_TRUE(std::filesystem::exists(blob));
  DiagnosticSink reader_sink;
  BuildReport reader = build(serial(server.url()), reader_sink);
  EXPECT_EQ(text_of(reader_sink), "");
  EXPECT_EQ(reader.compiled, 0u);
}

// The eviction recipe of docs/remote-cache.md (examples/remote_cache/evict.sh) keeps the server's directory under its
// size by deleting the files read least recently first. The builds after it see misses, never errors, also with
// --remote-required, and an uploading build fills the server again.
TEST_F(Remote, TheEvictionRecipeDeletesTheLeastRecentlyReadFilesFirstAndReadersSeeMisses) {
  testing::WebDav server;
  populate(server, {}, /*keep_pack=*/true);
  const PackEntry pack = pack_entry(server);
  // Access times a second apart in an order of the test's choosing: the finished pack's three files first (so the
  // reader below has to use the per-source entries), then the rest in reverse path order.
  std::vector<std::filesystem::path> files{pack.record, pack.manifest, pack.archive};
  std::vector<std::filesystem::path> rest = stored(server, "ac");
  for (const auto& blob : stored(server, "cas")) rest.push_back(blob);
  std::sort(rest.rbegin(), rest.rend());
  for (const auto& file : rest)
    if (std::find(files.begin(), files.end(), file) == files.end()) files.push_back(file);
  uintmax_t total = 0, pack_bytes_on_disk = 0;
  for (size_t i = 0; i < files.size(); ++i) {
    const timespec times[2] = {{static_cast<time_t>(1'700'000'000 + i), 0}, {0, UTIME_OMIT}};
    ASSERT_EQ(::utimensat(AT_FDCWD, files[i].c_str(), times, 0), 0) << files[i];
    total += std::filesystem::file_size(files[i]);
    if (i < 3) pack_bytes_on_disk += std::filesystem::file_size(files[i]);
  }
  const uintmax_t limit = (total - pack_bytes_on_disk) / 2;
  size_t evicted = 0;
  for (uintmax_t left = total; left > limit; ++evicted) left -= std::filesystem::file_size(files[evicted]);
  ASSERT_GT(evicted, 3u);

  const testing::RunResult evict = testing::run(
      {"/bin/sh", std::string(KILN_SOURCE_DIR) + "/examples/remote_cache/evict.sh", server.data().string(), std::to_string(limit)},
      dir.path());
  ASSERT_EQ(evict.exit_code, 0) << evict.out << evict.err;
  uintmax_t kept = 0;
  for (size_t i = 0; i < files.size(); ++i) {
    EXPECT_EQ(std::filesystem::exists(files[i]), i >= evicted) << i << " " << files[i];
    if (i >= evicted) kept += std::filesystem::file_size(files[i]);
  }
  EXPECT_LE(kept, limit);

  const auto wanted = reference();
  RemoteCacheOptions required = serial(server.url());
  required.required = true;
  DiagnosticSink reader_sink;
  BuildReport reader = build(required, reader_sink);
  EXPECT_TRUE(reader.ok) << text_of(reader_sink);
  EXPECT_EQ(text_of(reader_sink), "");
  EXPECT_EQ(reader.remote.errors, 0u);
  EXPECT_FALSE(reader.remote.pack_fetched);
  EXPECT_GE(reader.compiled, 1u);
  EXPECT_TRUE(pack_bytes(last_output) == wanted);

  DiagnosticSink uploader_sink;
  BuildReport uploader = build(serial(server.url(), true), uploader_sink);
  EXPECT_TRUE(uploader.ok) << text_of(uploader_sink);
  DiagnosticSink refilled_sink;
  BuildReport refilled = build(required, refilled_sink);
  EXPECT_TRUE(refilled.ok) << text_of(refilled_sink);
  EXPECT_TRUE(refilled.remote.pack_fetched) << "the uploading build put the finished pack back";
  EXPECT_EQ(refilled.compiled, 0u);
  EXPECT_TRUE(pack_bytes(last_output) == wanted);
}

// The script refuses what it cannot use, and deletes nothing then.
TEST(RemoteEviction, TheRecipeRefusesAMissingDirectoryOrASizeItCannotRead) {
  testing::TempDir dir;
  dir.write("data/ac/0a", "record");
  const std::string script = std::string(KILN_SOURCE_DIR) + "/examples/remote_cache/evict.sh";
  for (const std::vector<std::string>& args : std::vector<std::vector<std::string>>{
           {(dir / "data").string(), "lots"}, {(dir / "nothing-here").string(), "1G"}, {(dir / "data").string()}}) {
    std::vector<std::string> argv{"/bin/sh", script};
    argv.insert(argv.end(), args.begin(), args.end());
    EXPECT_EQ(testing::run(argv, dir.path()).exit_code, 2) << args.front();
  }
  EXPECT_TRUE(std::filesystem::exists(dir / "data/ac/0a"));
}

struct Https : Remote {};

TEST_F(Https, WithTheTestCaTheRemoteWorksAndWithoutItNothingIsSentInClear) {
  testing::WebDav server({{}, true});
  RemoteCacheOptions trusted = serial(server.url(), true);
  trusted.ca_file = server.ca_file();
  populate(server, trusted);
  trusted.upload = false;
  DiagnosticSink sink;
  BuildReport hit = build(trusted, sink);
  EXPECT_EQ(hit.remote.hits, 6u);
  EXPECT_EQ(text_of(sink), "");
  // The system's CAs do not know the test CA: verification fails, and kiln neither skips it nor tries http://.
  expect_survived(serial(server.url()),
                  server.url() + ": warning[K1701]: cannot reach the remote cache: SSL peer certificate or SSH remote key "
                                 "was not OK\n" + kSwitchedOff + kNeverFails,
                  DiagId::RemoteUnreachable);
}

}  // namespace
}  // namespace kiln

namespace kiln {
namespace {

// Two machines through the CLI: each a checkout with its own local cache, one nginx between them. The same
// files, at the same path or elsewhere (the inputs hash names files by their path from the pack), fetch the
// finished pack, byte for byte; a checkout whose pack definition differs by one byte (another inputs hash, the same
// stage sources) fetches every stage source and writes the same archive. It compiles nothing.
TEST(RemoteCli, ASecondMachineCompilesNothingAndWritesTheSamePack) {
  testing::Nginx server;
  testing::TempDir root;
  write_library(root, "ws");
  ::setenv("KILN_REMOTE", server.url().c_str(), 1);
  auto first = testing::run_kiln({"build", "p.pack.json", "-o", "out", "--cache", "../cacheA", "--remote-upload"}, root / "ws");
  ::unsetenv("KILN_REMOTE");
  ASSERT_EQ(first.exit_code, 0) << first.err;
  EXPECT_EQ(first.err, "");
  EXPECT_NE(first.out.find("  remote cache: hits 0, misses 6, uploads 12 ("), std::string::npos) << first.out;
  std::filesystem::rename(root / "ws", root / "machineA");

  write_library(root, "ws");
  auto second = testing::run_kiln({"build", "p.pack.json", "-o", "out", "--cache", "../cacheB", "--remote", server.url()},
                                  root / "ws");
  ASSERT_EQ(second.exit_code, 0) << second.err;
  EXPECT_EQ(second.err, "");
  EXPECT_EQ(second.out.rfind("kiln: fetched from the remote cache: out/p.manifest.json\n", 0), 0u) << second.out;
  EXPECT_NE(second.out.find("  remote cache: the finished pack of these inputs, "), std::string::npos) << second.out;
  EXPECT_TRUE(pack_bytes(root / "machineA/out") == pack_bytes(root / "ws/out"));

  write_library(root, "elsewhere/deeper");
  auto moved = testing::run_kiln({"build", "p.pack.json", "-o", "out", "--cache", "../cacheD", "--remote", server.url()},
                                 root / "elsewhere/deeper");
  ASSERT_EQ(moved.exit_code, 0) << moved.err;
  EXPECT_EQ(moved.out.rfind("kiln: fetched from the remote cache: out/p.manifest.json\n", 0), 0u) << moved.out;
  EXPECT_TRUE(pack_bytes(root / "machineA/out") == pack_bytes(root / "elsewhere/deeper/out"));

  std::filesystem::remove_all(root / "elsewhere");
  write_library(root, "elsewhere/deeper");
  std::ofstream(root / "elsewhere/deeper/p.pack.json", std::ios::app) << "\n";
  auto third = testing::run_kiln({"build", "p.pack.json", "-o", "out", "--cache", "../cacheC", "--remote", server.url()},
                                 root / "elsewhere/deeper");
  ASSERT_EQ(third.exit_code, 0) << third.err;
  EXPECT_NE(third.out.find("  compiled 0 (back ends 0,"), std::string::npos) << third.out;
  EXPECT_NE(third.out.find("  remote cache: hits 6, misses 0, uploads 0 (0 blobs), "), std::string::npos) << third.out;
  EXPECT_EQ(testing::read_archive(root / "machineA/out/p.manifest.json"),
            testing::read_archive(root / "elsewhere/deeper/out/p.manifest.json"));
}

// Shard numbers are plain decimals: "1/2junk" was taken as 1/2, "0/4294967297" wrapped to an unsharded build, a
// Slurm count past 2^32 gave "shard 5/2", and a non-numeric SLURM_ARRAY_TASK_ID was reported as absent.
TEST(RemoteCli, ShardNumbersThatAreNotPlainDecimalsAreRefused) {
  testing::TempDir root;
  write_library(root, "ws");
  const std::string url = "http://127.0.0.1:" + std::to_string(testing::free_port());
  auto shard = [&](const std::string& value) {
    return testing::run_kiln({"build", "p.pack.json", "-o", "out", "--remote", url, "--shard", value}, root / "ws");
  };
  for (const char* text : {"1/2junk", "0/4294967297", "-1/2", "+0/2", "0x1/2", "1/"}) {
    auto r = shard(text);
    EXPECT_EQ(r.exit_code, 1) << text;
    EXPECT_EQ(r.err, std::string("kiln: error: --shard wants I/N with I < N, or auto (got '") + text + "')\n");
  }
  auto many = shard("0/999999999");
  EXPECT_EQ(many.err, "kiln: error: --shard: 999999999 shards is more than kiln splits a build into (100000)\n");
  ::setenv("SLURM_ARRAY_TASK_ID", "abc", 1);
  auto letters = shard("auto");
  EXPECT_EQ(letters.err, "kiln: error: --shard auto read SLURM_ARRAY_TASK_ID='abc', which is not a number (a decimal "
                         "integer of at most 9 digits)\n");
  ::setenv("SLURM_ARRAY_TASK_ID", "5", 1);
  ::setenv("SLURM_ARRAY_TASK_MIN", "0", 1);
  ::setenv("SLURM_ARRAY_TASK_MAX", "4294967297", 1);
  auto wrapped = shard("auto");
  EXPECT_EQ(wrapped.err, "kiln: error: --shard auto read SLURM_ARRAY_TASK_MAX='4294967297', which is not a number (a "
                         "decimal integer of at most 9 digits)\n");
  for (const char* name : {"SLURM_ARRAY_TASK_ID", "SLURM_ARRAY_TASK_MIN", "SLURM_ARRAY_TASK_MAX"}) ::unsetenv(name);
  EXPECT_FALSE(std::filesystem::exists(root / "ws/out/p.manifest.json"));
}

// --shard auto reads a Slurm job array's task index and count (GitLab's CI_NODE_INDEX is 1-based; a Kubernetes
// Indexed Job's JOB_COMPLETION_INDEX with KILN_SHARD_COUNT).
TEST(RemoteCli, ShardAutoReadsTheSchedulersIndexAndCountFromTheEnvironment) {
  testing::Nginx server;
  testing::TempDir root;
  write_library(root, "ws");
  ::setenv("SLURM_ARRAY_TASK_ID", "5", 1);
  ::setenv("SLURM_ARRAY_TASK_MIN", "4", 1);
  ::setenv("SLURM_ARRAY_TASK_MAX", "5", 1);
  auto slurm = testing::run_kiln({"build", "p.pack.json", "-o", "out", "--cache", "c1", "--remote", server.url(), "--shard", "auto"},
                                 root / "ws");
  for (const char* name : {"SLURM_ARRAY_TASK_ID", "SLURM_ARRAY_TASK_MIN", "SLURM_ARRAY_TASK_MAX"}) ::unsetenv(name);
  EXPECT_EQ(slurm.exit_code, 0) << slurm.err;
  EXPECT_EQ(slurm.out.rfind("kiln: shard 1/2 of out/p.manifest.json: compiled ", 0), 0u) << slurm.out;
  ::setenv("CI_NODE_INDEX", "1", 1);
  ::setenv("CI_NODE_TOTAL", "2", 1);
  auto gitlab = testing::run_kiln({"build", "p.pack.json", "-o", "out", "--cache", "c2", "--remote", server.url(), "--shard", "auto"},
                                  root / "ws");
  ::unsetenv("CI_NODE_INDEX");
  ::unsetenv("CI_NODE_TOTAL");
  EXPECT_EQ(gitlab.out.rfind("kiln: shard 0/2 of out/p.manifest.json: compiled ", 0), 0u) << gitlab.out;
  // The shards share one output directory: the second, finding the first's bundle, assembled the pack there.
  EXPECT_NE(gitlab.out.find("every other shard had finished: wrote the pack from 2 shard bundles"), std::string::npos)
      << gitlab.out;
  // Kubernetes exports the index only: the count comes from the job's spec, as KILN_SHARD_COUNT.
  ::setenv("JOB_COMPLETION_INDEX", "1", 1);
  auto no_count = testing::run_kiln({"build", "p.pack.json", "-o", "out", "--cache", "c4", "--remote", server.url(),
                                     "--shard", "auto"}, root / "ws");
  EXPECT_EQ(no_count.exit_code, 1);
  EXPECT_EQ(no_count.err, "kiln: error: --shard auto found JOB_COMPLETION_INDEX (a Kubernetes Indexed Job) but no "
                          "KILN_SHARD_COUNT: set it to the job's completions\n");
  ::setenv("KILN_SHARD_COUNT", "2", 1);
  auto kubernetes = testing::run_kiln({"build", "p.pack.json", "-o", "out", "--cache", "c5", "--remote", server.url(),
                                       "--shard", "auto"}, root / "ws");
  // A count that does not match the scheduler's: the error says what was read, not only "auto".
  ::setenv("JOB_COMPLETION_INDEX", "2", 1);
  auto beyond = testing::run_kiln({"build", "p.pack.json", "-o", "out", "--cache", "c7", "--remote", server.url(),
                                   "--shard", "auto"}, root / "ws");
  EXPECT_EQ(beyond.exit_code, 1);
  EXPECT_EQ(beyond.err, "kiln: error: --shard auto read shard 2 of 2 from JOB_COMPLETION_INDEX=2, KILN_SHARD_COUNT=2: a "
                        "shard's index must be at least 0 and below the count (does the count match the scheduler's?)\n");
  ::unsetenv("JOB_COMPLETION_INDEX");
  ::unsetenv("KILN_SHARD_COUNT");
  EXPECT_EQ(kubernetes.exit_code, 0) << kubernetes.err;
  EXPECT_EQ(kubernetes.out, "kiln: shard 1/2: up to date: out/p.manifest.json\n");
  auto nothing = testing::run_kiln({"build", "p.pack.json", "-o", "out", "--cache", "c6", "--remote", server.url(),
                                    "--shard", "auto"}, root / "ws");
  EXPECT_EQ(nothing.exit_code, 1);
  EXPECT_EQ(nothing.err, "kiln: error: --shard auto found no SLURM_ARRAY_TASK_ID, CI_NODE_INDEX/CI_NODE_TOTAL or "
                         "JOB_COMPLETION_INDEX in the environment\n");
  auto merge = testing::run_kiln({"build", "p.pack.json", "-o", "out", "--cache", "c3", "--remote", server.url()}, root / "ws");
  EXPECT_EQ(merge.out.rfind("kiln: up to date: out/p.manifest.json", 0), 0u) << merge.out;
  auto alone = testing::run_kiln({"build", "p.pack.json", "-o", "out", "--shard", "0/2"}, root / "ws");
  EXPECT_EQ(alone.exit_code, 1);
  EXPECT_EQ(alone.err, "kiln: error: --shard needs a remote cache (--remote URL or KILN_REMOTE): the merge build reads the "
                       "shards' work there\n");
}

// The documented Slurm recipe on a real one-node cluster: the shards are a job array, the merge a job that runs
// only after every shard succeeded (afterok), all against one nginx.
struct RemoteSlurm : ::testing::Test {
  void SetUp() override {
    if (::geteuid() != 0) GTEST_SKIP() << "slurmd runs jobs only as root";
  }
  testing::TempDir root;
  // sbatch's arguments for a job in `ws` whose output goes to `log` (%a: the array index).
  std::vector<std::string> job(const std::string& log, std::vector<std::string> options, const std::string& script) {
    std::vector<std::string> argv{"/usr/bin/sbatch", "--parsable", "--chdir", (root / "ws").string(), "--output",
                                  (root / log).string()};
    argv.insert(argv.end(), options.begin(), options.end());
    argv.insert(argv.end(), {"--wrap", script});
    return argv;
  }
  static std::string job_id(const testing::RunResult& submitted) {
    return submitted.out.substr(0, submitted.out.find_first_of(";\n"));
  }
};

TEST_F(RemoteSlurm, AJobArrayOfShardsAndAnAfterokMergeWriteThePackOfOneMachine) {
  testing::Nginx server;
  testing::SlurmCluster slurm;
  write_library(root, "ws");
  write_library(root, "alone");
  auto alone = testing::run_kiln({"build", "p.pack.json", "-o", "out", "--cache", "cache"}, root / "alone");
  ASSERT_EQ(alone.exit_code, 0) << alone.err;
  const std::string kiln = std::string(KILN_CLI_PATH) + " build p.pack.json -o out --remote " + server.url() + " --remote-required";
  auto shards = slurm.command(job("shard-%a.log", {"--array=0-2"}, kiln + " --cache cache-$SLURM_ARRAY_TASK_ID --shard auto"),
                              root.path());
  ASSERT_EQ(shards.exit_code, 0) << shards.err << slurm.logs();
  // --wait returns when the merge has ended; its exit code is the job's (0 also for a job cancelled unrun).
  // The merge uploads the finished pack, as docs/remote-cache.md's recipe does.
  auto merge = slurm.command(job("merge.log", {"--wait", "--kill-on-invalid-dep=yes", "--dependency=afterok:" + job_id(shards)},
                                 kiln + " --cache cache-merge --remote-upload"),
                             root.path());
  ASSERT_EQ(merge.exit_code, 0) << merge.err << slurm.logs();
  EXPECT_EQ(slurm.job_state(job_id(merge)), "COMPLETED None");

  // Every shard compiled its share and they add up to the one-machine build; the merge compiled nothing.
  size_t compiled = 0;
  for (int shard = 0; shard < 3; ++shard) {
    const std::string log = testing::read_file(root / ("shard-" + std::to_string(shard) + ".log"));
    const std::string prefix = "kiln: shard " + std::to_string(shard) + "/3 of out/p.manifest.json: compiled ";
    ASSERT_EQ(log.rfind(prefix, 0), 0u) << log;
    compiled += std::stoul(log.substr(prefix.size()));
  }
  // The shards share the checkout's output directory: the shard that finished last wrote the pack there, and the merge
  // finds it up to date (or, had that shard's assembly failed, assembles it from the bundles).
  const std::string merged = testing::read_file(root / "merge.log");
  EXPECT_TRUE(merged.rfind("kiln: up to date: out/p.manifest.json", 0) == 0 ||
              merged.find("  compiled 0 (back ends 0,") != std::string::npos)
      << merged;
  EXPECT_NE(alone.out.find("  compiled " + std::to_string(compiled) + " (back ends"), std::string::npos)
      << "the shards compiled " << compiled << "\n" << alone.out;
  EXPECT_TRUE(pack_bytes(root / "ws/out") == pack_bytes(root / "alone/out")) << "the merged pack differs from one machine's";
  // A later reader of the commit fetches the finished pack the merge uploaded.
  write_library(root, "reader");
  auto reader = testing::run_kiln({"build", "p.pack.json", "-o", "out", "--cache", "cache", "--remote", server.url()}, root / "reader");
  EXPECT_EQ(reader.exit_code, 0) << reader.err;
  EXPECT_EQ(reader.out.rfind("kiln: fetched from the remote cache: ", 0), 0u) << reader.out;
}

TEST_F(RemoteSlurm, AFailedShardKeepsTheMergeFromRunning) {
  testing::Nginx server;
  testing::SlurmCluster slurm;
  write_library(root, "ws");
  const std::string kiln = std::string(KILN_CLI_PATH) + " build p.pack.json -o out --remote " + server.url() + " --remote-required";
  auto shards = slurm.command(job("shard-%a.log", {"--array=0-2"},
                                  "if [ \"$SLURM_ARRAY_TASK_ID\" = 1 ]; then exit 3; fi; " + kiln +
                                      " --cache cache-$SLURM_ARRAY_TASK_ID --shard auto"),
                              root.path());
  ASSERT_EQ(shards.exit_code, 0) << shards.err << slurm.logs();
  auto merge = slurm.command(job("merge.log", {"--wait", "--kill-on-invalid-dep=yes", "--dependency=afterok:" + job_id(shards)},
                                 kiln + " --cache cache-merge"),
                             root.path());
  EXPECT_EQ(slurm.job_state(job_id(merge)), "CANCELLED DependencyNeverSatisfied") << merge.err << slurm.logs();
  EXPECT_FALSE(std::filesystem::exists(root / "merge.log")) << "the merge ran";
  EXPECT_FALSE(std::filesystem::exists(root / "ws/out/p.manifest.json")) << "a pack was written";
}

// A daemon that fails to start (here slurmd, as in a chroot without cgroups) must not leave the others running:
// the constructor that throws stops and reaps munged and slurmctld itself. Not root-only: no job runs.
bool process_exists(pid_t pid) { return ::kill(pid, 0) == 0 || errno != ESRCH; }

TEST(RemoteSlurmCleanUp, EveryDaemonIsStoppedWhenOneFailsToStart) {
  std::vector<pid_t> spawned;
  std::string message;
  try {
    testing::SlurmCluster slurm({"/bin/false", &spawned});
    ADD_FAILURE() << "a cluster whose slurmd exits at once started";
  } catch (const std::runtime_error& error) {
    message = error.what();
  }
  EXPECT_EQ(message.rfind("a Slurm daemon exited before idle node", 0), 0u) << message;
  ASSERT_EQ(spawned.size(), 3u) << "munged, slurmctld and the failing slurmd";
  for (pid_t pid : spawned) EXPECT_FALSE(process_exists(pid)) << "daemon " << pid << " is still running";
  EXPECT_EQ(std::getenv("SLURM_CONF"), nullptr) << "the cluster's configuration outlived it";
}

TEST(RemoteCli, RemoteRequiredMakesAnUnreachableServerAnError) {
  testing::TempDir root;
  write_library(root, "ws");
  const std::string url = "http://127.0.0.1:" + std::to_string(testing::free_port());
  auto run = testing::run_kiln({"build", "p.pack.json", "-o", "out", "--cache", "cache", "--remote", url, "--remote-required",
                                "-q"}, root / "ws");
  EXPECT_EQ(run.exit_code, 3);  // a required remote that cannot be used is the environment's fault
  EXPECT_EQ(run.err, url + ": error[K1701]: cannot reach the remote cache: Couldn't connect to server\n"
                           "  note: the remote cache is off for the rest of this build\n"
                           "kiln: 1 error(s)\n");
  EXPECT_FALSE(std::filesystem::exists(root / "ws/out/p.manifest.json"));
}

}  // namespace
}  // namespace kiln

namespace kiln {
namespace {

// kiln_add_shader_pack(... DEFINES ... REMOTE <url> [REMOTE_UPLOAD]) in a CMake project, built with Ninja against a
// real nginx: the build tree that may upload fills the server; another build tree of the same project (its own
// kiln-cache) fetches the finished pack and compiles nothing; the define reaches the shader (it #errors without it)
// and is part of the remote keys (another value compiles again) and of the build's inputs (changing it rebuilds).
TEST(RemoteCli, ACMakeProjectsPackUploadsAndAnotherBuildTreeFetchesItWithItsDefines) {
  testing::Nginx server;
  testing::TempDir root;
  root.write("project/S.hlsl",
             "#pragma multi_compile_fragment _ FOG\n#ifndef TINT\n#error TINT is not defined\n#endif\n"
             "float4 V(float4 p : POSITION) : SV_Position { return p; }\n"
             "float4 F(float4 p : SV_Position) : SV_Target {\n  float c = TINT;\n#ifdef FOG\n  c *= exp2(-p.z);\n#endif\n"
             "  return float4(c, c, c, 1.0);\n}\n");
  root.write("project/p.pack.json", R"({"name": "p",
      "passes": [{"name": "P", "source": "S.hlsl", "stages": {"vertex": "V", "fragment": "F"}}]})");
  root.write("project/CMakeLists.txt",
             "cmake_minimum_required(VERSION 3.25)\nproject(consumer NONE)\n"
             "add_executable(kiln::kiln IMPORTED)\n"
             "set_target_properties(kiln::kiln PROPERTIES IMPORTED_LOCATION \"" KILN_CLI_PATH "\")\n"
             "include(\"" KILN_SOURCE_DIR "/cmake/KilnShaderPack.cmake\")\n"
             "set(TINT 0.5 CACHE STRING \"\")\noption(UPLOAD \"\" OFF)\nset(upload \"\")\n"
             "if(UPLOAD)\n  set(upload REMOTE_UPLOAD)\nendif()\n"
             "kiln_add_shader_pack(shaders PACK p.pack.json DEFINES TINT=${TINT} REMOTE " + server.url() +
                 " ${upload}\n  OPTIONS --summary-json ${CMAKE_BINARY_DIR}/summary.json)\n");
  const auto configure_and_build = [&](const std::string& tree, std::vector<std::string> cache_entries) {
    std::vector<std::string> configure{KILN_CMAKE_COMMAND, "-S", (root / "project").string(), "-B", (root / tree).string(), "-G", "Ninja"};
    configure.insert(configure.end(), cache_entries.begin(), cache_entries.end());
    auto configured = testing::run(configure, root.path());
    EXPECT_EQ(configured.exit_code, 0) << configured.out << configured.err;
    auto built = testing::run({KILN_CMAKE_COMMAND, "--build", (root / tree).string()}, root.path());
    EXPECT_EQ(built.exit_code, 0) << built.out << built.err;
    return nlohmann::json::parse(testing::read_file(root / tree / "summary.json"));
  };

  const nlohmann::json ci = configure_and_build("ci", {"-DUPLOAD=ON"});
  EXPECT_EQ(ci["compiled"], 3);
  EXPECT_EQ(ci["remote"]["configured"], true);
  EXPECT_GT(ci["remote"]["uploads"].get<int>(), 0);
  EXPECT_FALSE(testing::files_below(server.data()).empty()) << "nothing was uploaded";

  // A developer's build tree: read-only, its own local cache.
  const nlohmann::json developer = configure_and_build("developer", {});
  EXPECT_EQ(developer["compiled"], 0);
  EXPECT_EQ(developer["remote"]["pack_fetched"], true);
  EXPECT_EQ(developer["remote"]["uploads"], 0);
  EXPECT_TRUE(pack_bytes(root / "ci/shaders") == pack_bytes(root / "developer/shaders"));

  // Another define is another pack: the remote has none of it, and the shader's code changes.
  const nlohmann::json other = configure_and_build("other", {"-DTINT=0.25"});
  EXPECT_EQ(other["remote"]["pack_fetched"], false);
  EXPECT_EQ(other["remote"]["hits"], 0);
  EXPECT_GT(other["compiled"].get<int>(), 0);
  EXPECT_NE(testing::read_archive(root / "ci/shaders/p.manifest.json"),
            testing::read_archive(root / "other/shaders/p.manifest.json"));

  // Changing DEFINES in a configured tree rebuilds its pack; building again with nothing changed does not.
  auto reconfigured = testing::run({KILN_CMAKE_COMMAND, "-DTINT=0.25", (root / "developer").string()}, root.path());
  ASSERT_EQ(reconfigured.exit_code, 0) << reconfigured.err;
  auto rebuilt = testing::run({KILN_CMAKE_COMMAND, "--build", (root / "developer").string()}, root.path());
  EXPECT_NE(rebuilt.out.find("kiln: building shader pack 'p'"), std::string::npos) << rebuilt.out;
  EXPECT_EQ(testing::read_archive(root / "developer/shaders/p.manifest.json"),
            testing::read_archive(root / "other/shaders/p.manifest.json"));
  auto again = testing::run({KILN_CMAKE_COMMAND, "--build", (root / "developer").string()}, root.path());
  EXPECT_EQ(again.out.find("kiln: building shader pack"), std::string::npos) << again.out;
}

}  // namespace
}  // namespace kiln
