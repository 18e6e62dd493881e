// SPDX-License-Identifier: Apache-2.0
// On-demand variants (docs/development-loop.md, "On-demand variants"; issue 61 item 3): kiln watch --serve and a
// reader in development mode (kiln/development_reader.hpp). The endpoint is untrusted input: hostile requests are sent
// as raw bytes on 127.0.0.1 and watch must answer each with a 4xx (or drop it) and keep serving. Every wait is on an
// event (a status line, a socket's answer, the reader's update descriptor), never on time.
#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdlib>
#include <set>

#include <nlohmann/json.hpp>

#include "kiln/development_reader.hpp"
#include "kiln/kiln_reader_dev.h"
#include "kiln/pack_reader.hpp"
#include "test_support.hpp"
#include "usage_log_text.hpp"

namespace kiln {
namespace {

const char* kPack = R"({"name": "p", "include_dirs": ["lib"], "budget": 64,
  "passes": [{"name": "P", "source": "S.hlsl", "stages": {"vertex": "V", "fragment": "F"}}]})";
const char* kShader =
    "#pragma multi_compile _ A B\n#include \"Colour.hlsl\"\n"
    "float4 V(float4 p : POSITION) : SV_Position { return p; }\n"
    "float4 F() : SV_Target {\n#if defined(A)\n  return colour() * 2.0;\n#elif defined(B)\n  return colour() * 3.0;\n"
    "#else\n  return colour();\n#endif\n}\n";

using testing::usage_log;

bool contains(const std::string& text, const std::string& part) { return text.find(part) != std::string::npos; }

// A connection to 127.0.0.1:port, closed when it goes.
struct Socket {
  int fd = -1;
  explicit Socket(uint16_t port) {
    fd = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
    sockaddr_in address{};
    address.sin_family = AF_INET;
    address.sin_port = htons(port);
    address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    if (::connect(fd, reinterpret_cast<sockaddr*>(&address), sizeof address) != 0) ADD_FAILURE() << "connect: " << errno;
  }
  ~Socket() { ::close(fd); }
  bool send(std::string_view bytes) {
    while (!bytes.empty()) {
      const ssize_t n = ::send(fd, bytes.data(), bytes.size(), MSG_NOSIGNAL);
      if (n <= 0) return false;
      bytes.remove_prefix(static_cast<size_t>(n));
    }
    return true;
  }
  // Everything until the server closes the connection (every request here says Connection: close).
  std::string answer() {
    std::string text;
    char buffer[4096];
    for (;;) {
      const ssize_t n = ::recv(fd, buffer, sizeof buffer, 0);
      if (n <= 0) return text;
      text.append(buffer, static_cast<size_t>(n));
    }
  }
};

std::string post(const std::string& body, const std::string& path = "/v1/variant") {
  return "POST " + path + " HTTP/1.1\r\nHost: 127.0.0.1\r\nConnection: close\r\nContent-Type: application/json\r\n"
         "Content-Length: " + std::to_string(body.size()) + "\r\n\r\n" + body;
}
std::string status_of(const std::string& answer) { return answer.substr(0, answer.find("\r\n")); }

struct DevelopmentEndpoint : ::testing::Test {
  testing::TempDir dir;
  std::unique_ptr<testing::BackgroundProcess> kiln;
  uint16_t port = 0;

  void SetUp() override {
    ::unsetenv("KILN_DEVELOPMENT_ENDPOINT");
    dir.write("p.pack.json", kPack);
    dir.write("S.hlsl", kShader);
    dir.write("lib/Colour.hlsl", "float4 colour() { return 0.25; }\n");
    dir.write("usage/run.json", usage_log({"A"}));
  }
  // kiln watch serving the in-use pack (variant [A] only): returns once round 1 is published.
  void start(std::vector<std::string> extra = {"--in-use-only"}) {
    start_with("usage/run.json", extra, "round 1: start; in use: 1 variant");
  }
  // kiln watch with `usage` as its log and `extra` options: returns once round 1, whose line has `round`, is published.
  void start_with(const std::string& usage, std::vector<std::string> extra, const std::string& round) {
    std::vector<std::string> args{KILN_CLI_PATH, "watch", "p.pack.json", "-o", "out", "--cache", "cache", "-j", "1",
                                  "--usage", usage, "--serve", "127.0.0.1:0"};
    args.insert(args.end(), extra.begin(), extra.end());
    kiln = std::make_unique<testing::BackgroundProcess>(args, dir.path());
    const std::string serving = status();
    ASSERT_TRUE(contains(serving, "kiln watch: serving variants on http://127.0.0.1:")) << serving;
    const std::string endpoint = testing::read_file(dir / "out/p.endpoint");
    ASSERT_TRUE(contains(serving, endpoint.substr(0, endpoint.size() - 1))) << serving << " / " << endpoint;
    port = static_cast<uint16_t>(std::stoul(endpoint.substr(endpoint.rfind(':') + 1)));
    const std::string first = status();
    ASSERT_TRUE(contains(first, round)) << first << "\n" << kiln->err();
  }
  std::string status() {
    std::optional<std::string> line = kiln->next_line();
    EXPECT_TRUE(line) << "kiln watch ended or wrote nothing; its stderr:\n" << kiln->err();
    return line.value_or("");
  }
  std::string request(const std::string& bytes) {
    Socket socket(port);
    socket.send(bytes);
    return socket.answer();
  }
  std::filesystem::path manifest() const { return dir / "out/p.manifest.json"; }
};

// (a) Wait: the in-use pack lacks [B]; the reader asks watch, waits, switches to the pack that has it and selects it.
TEST_F(DevelopmentEndpoint, AReaderThatWaitsGetsTheVariantThePackLacked) {
  start();
  PackReader reader = PackReader::open(manifest());
  ASSERT_EQ(reader.try_select("P", {"B"}).code(), PackError::Code::Stripped);
  PackResult<DevelopmentReader> development = DevelopmentReader::open(reader, manifest());
  ASSERT_TRUE(development) << development.message();
  PackResult<SelectedVariant> selected = development->select_or_wait("P", {"B"}, std::chrono::seconds(120));
  ASSERT_TRUE(selected) << selected.message() << "\n" << kiln->err();
  EXPECT_EQ(selected->keywords, std::vector<std::string>{"B"});
  EXPECT_TRUE(contains(status(), "request P [B]: built into p.")) << kiln->err();
  EXPECT_TRUE(reader.try_select("P", {"A"})) << "the in-use variants stay";
  // Asked for again, it is in the pack: served without a build.
  PackResult<std::string> again = development->request("P", {"B"}, std::chrono::seconds(120));
  ASSERT_TRUE(again) << again.message();
  EXPECT_TRUE(contains(status(), "request P [B]: in " + *again));
  // A request stays in the in-use set: the next round's in-use pack has it.
  dir.write("lib/Colour.hlsl", "float4 colour() { return 0.5; }\n");
  EXPECT_TRUE(contains(status(), "in use: 2 variants")) << kiln->err();
  EXPECT_EQ(kiln->end(SIGTERM), 0);
  EXPECT_FALSE(std::filesystem::exists(dir / "out/p.endpoint")) << "the endpoint file goes with watch";
}

// (b) Nearest now: the reader gets the nearest variant at once, and a later poll_update() (woken by its update
// descriptor) brings the real one.
TEST_F(DevelopmentEndpoint, AReaderThatTakesTheNearestVariantGetsTheRealOneFromALaterPoll) {
  start();
  PackReader reader = PackReader::open(manifest());
  PackResult<int> fd = reader.update_fd();
  ASSERT_TRUE(fd) << fd.message();
  PackResult<DevelopmentReader> development = DevelopmentReader::open(reader, manifest());
  ASSERT_TRUE(development) << development.message();
  PackResult<DevelopmentReader::Selection> now = development->select_or_nearest("P", {"B"});
  ASSERT_TRUE(now) << now.message();
  EXPECT_TRUE(now->nearest);
  EXPECT_EQ(now->variant.keywords, std::vector<std::string>{"A"});  // the only variant of the in-use pack
  bool added = false;
  while (!added) {
    pollfd entry{*fd, POLLIN, 0};
    ASSERT_EQ(::poll(&entry, 1, 120000), 1) << "no pack switch; kiln watch's stderr:\n" << kiln->err();
    PackResult<PackUpdate> update = reader.poll_update();
    ASSERT_TRUE(update) << update.message();
    for (const VariantChange& change : update->changes)
      added = added || (change.kind == VariantChange::Kind::Added && change.keywords == std::vector<std::string>{"B"});
  }
  PackResult<DevelopmentReader::Selection> later = development->select_or_nearest("P", {"B"});
  ASSERT_TRUE(later) << later.message();
  EXPECT_FALSE(later->nearest);
  EXPECT_EQ(later->variant.keywords, std::vector<std::string>{"B"});
  EXPECT_EQ(kiln->end(SIGTERM), 0);
}

// The same two modes from C (kiln/kiln_reader_dev.h): the pack's id tables follow the switch.
TEST_F(DevelopmentEndpoint, FromCBothModesServeTheMissingVariant) {
  start();
  kiln_pack* pack = nullptr;
  kiln_error error{};
  ASSERT_EQ(kiln_pack_open(manifest().c_str(), &pack, &error), KILN_OK) << error.message;
  kiln_development* development = nullptr;
  ASSERT_EQ(kiln_development_from_environment(pack, manifest().c_str(), &development, &error), KILN_OK);
  EXPECT_EQ(development, nullptr) << "KILN_DEVELOPMENT_ENDPOINT is unset";
  ::setenv("KILN_DEVELOPMENT_ENDPOINT", "auto", 1);
  ASSERT_EQ(kiln_development_from_environment(pack, manifest().c_str(), &development, &error), KILN_OK) << error.message;
  ::unsetenv("KILN_DEVELOPMENT_ENDPOINT");
  ASSERT_NE(development, nullptr);

  const char* b[] = {"B"};
  uint32_t variant = 0;
  ASSERT_EQ(kiln_development_select_or_wait(development, "P", b, 1, 120000, &variant, &error), KILN_OK) << error.message;
  EXPECT_TRUE(contains(status(), "request P [B]: built into p."));
  EXPECT_EQ(kiln_select_by_names(pack, "P", b, 1, 0, &variant, &error), KILN_OK) << error.message;

  const char* none[] = {"A", "B"};  // two of one group: an error select gives, not a request
  int nearest = -1;
  EXPECT_EQ(kiln_development_select_or_nearest(development, "P", none, 2, &variant, &nearest, &error), KILN_ERROR_CONFLICTING_KEYWORDS);
  ASSERT_EQ(kiln_development_select_or_nearest(development, "P", nullptr, 0, &variant, &nearest, &error), KILN_OK) << error.message;
  EXPECT_EQ(nearest, 1);
  int fd = -1;
  ASSERT_EQ(kiln_pack_update_fd(pack, &fd, &error), KILN_OK) << error.message;
  for (nearest = 1; nearest;) {
    ASSERT_TRUE(contains(status(), "request P []: built into p.")) << kiln->err();
    kiln_pack_update update;
    ASSERT_EQ(kiln_pack_poll_update(pack, &update, &error), KILN_OK) << error.message;
    ASSERT_EQ(kiln_development_select_or_nearest(development, "P", nullptr, 0, &variant, &nearest, &error), KILN_OK);
  }
  kiln_development_close(development);
  kiln_pack_close(pack);
  EXPECT_EQ(kiln->end(SIGTERM), 0);
}

// Without --in-use-only the full pack follows a request's in-use pack. [B] is broken, so the full pack fails and
// the in-use one ([A]) stays published; a request for [] is built into an in-use pack, and the full pack is tried again.
// A variant the published pack has is served without a build.
TEST_F(DevelopmentEndpoint, AfterARequestTheFullPackFollows) {
  std::string broken = kShader;
  broken.replace(broken.find("return colour() * 3.0;"), 22, "return undefinedB;");
  dir.write("S.hlsl", broken);
  std::vector<std::string> args{KILN_CLI_PATH, "watch", "p.pack.json", "-o", "out", "--cache", "cache", "-j", "1",
                                "--usage", "usage/run.json", "--serve", "127.0.0.1:0"};
  kiln = std::make_unique<testing::BackgroundProcess>(args, dir.path());
  ASSERT_TRUE(contains(status(), "serving variants on"));
  const std::string round = status();
  EXPECT_TRUE(contains(round, "; full: failed (1 error; the in-use pack stays)")) << round;
  const std::string endpoint = testing::read_file(dir / "out/p.endpoint");
  port = static_cast<uint16_t>(std::stoul(endpoint.substr(endpoint.rfind(':') + 1)));

  std::string answer = request(post(R"({"pass": "P", "keywords": ["A"]})"));
  EXPECT_TRUE(contains(answer, R"("compiled":false)")) << answer;
  EXPECT_TRUE(contains(status(), "request P [A]: in p.")) << kiln->err();
  answer = request(post(R"({"pass": "P", "keywords": []})"));
  EXPECT_EQ(status_of(answer), "HTTP/1.1 200 OK") << answer;
  EXPECT_TRUE(contains(answer, R"("compiled":true)")) << answer;
  EXPECT_TRUE(contains(status(), "request P []: built into p.")) << kiln->err();
  const std::string after = status();
  EXPECT_TRUE(contains(after, "kiln watch: after requests; full: failed (1 error; the in-use pack stays)")) << after;
  PackReader reader = PackReader::open(manifest());
  EXPECT_TRUE(reader.try_select("P", {}));
  EXPECT_TRUE(reader.try_select("P", {"A"}));
  EXPECT_EQ(kiln->end(SIGTERM), 0);
}

// A request that needs a build, arriving while the full pack is being built, stops that build, is served, and the
// full pack follows. The full build's compiler worker (KILN_WORKER: a script that runs the real one) waits at a
// gate: the script lets the first worker through (the round's in-use build), and the next one says so through one
// FIFO and waits for the test to open a second one.
TEST_F(DevelopmentEndpoint, ARequestDuringTheFullBuildStopsItIsServedAndTheFullPackFollows) {
  std::string broken = kShader;
  broken.replace(broken.find("return colour() * 3.0;"), 22, "return undefinedB;");
  dir.write("S.hlsl", broken);
  const std::filesystem::path worker = dir / "gate/worker";
  const std::string real = (std::filesystem::path(KILN_CLI_PATH).parent_path() / "kiln-worker").string();
  dir.write("gate/worker", "#!/bin/sh\nif [ -e \"$0.hold\" ]; then\n  if [ -s \"$0.hold\" ]; then : > \"$0.hold\"; "
                            "else echo started > \"$0.started\"; read line < \"$0.gate\"; fi\nfi\n"
                            "exec '" + real + "' \"$@\"\n");
  std::filesystem::permissions(worker, std::filesystem::perms::owner_all);
  ASSERT_EQ(::mkfifo((worker.string() + ".started").c_str(), 0600), 0);
  ASSERT_EQ(::mkfifo((worker.string() + ".gate").c_str(), 0600), 0);
  ::setenv("KILN_WORKER", worker.c_str(), 1);
  start_with("usage/run.json", {}, "; full: failed (1 error; the in-use pack stays)");
  ::unsetenv("KILN_WORKER");

  dir.write("gate/worker.hold", "let the in-use build's worker through");
  dir.write("lib/Colour.hlsl", "float4 colour() { return 0.5; }\n");
  EXPECT_EQ(testing::read_file(worker.string() + ".started"), "started\n");  // the full build waits for its worker
  std::filesystem::remove(dir / "gate/worker.hold");
  Socket socket(port);
  ASSERT_TRUE(socket.send(post(R"({"pass": "P", "keywords": []})")));  // not in the in-use pack: needs a build
  std::string line = status();
  EXPECT_TRUE(contains(line, "request P []: held: the full build stops for it")) << line;
  std::ofstream(worker.string() + ".gate") << "go\n";
  line = status();
  EXPECT_TRUE(contains(line, "round 2: lib/Colour.hlsl changed; in use: 1 variant (")) << line;
  EXPECT_TRUE(contains(line, "; full: interrupted by a variant request (built again after it)")) << line;
  line = status();
  EXPECT_TRUE(contains(line, "request P []: built into p.")) << line;
  const std::string answer = socket.answer();
  EXPECT_EQ(status_of(answer), "HTTP/1.1 200 OK") << answer;
  EXPECT_TRUE(contains(answer, R"("compiled":true)")) << answer;
  line = status();
  EXPECT_TRUE(contains(line, "kiln watch: after requests; full: failed (1 error; the in-use pack stays)")) << line;
  PackReader reader = PackReader::open(manifest());
  EXPECT_TRUE(reader.try_select("P", {}));
  EXPECT_TRUE(reader.try_select("P", {"A"}));
  EXPECT_EQ(kiln->end(SIGTERM), 0);
}

// Hostile bytes: each is answered with a 4xx (or its connection dropped), and watch keeps serving, also while a
// client that sends half a request and stops holds its connection open.
TEST_F(DevelopmentEndpoint, HostileRequestsAreRefusedAndTheLoopKeepsServing) {
  start();
  Socket slow(port);  // slowloris: headers and half a body, never the rest
  ASSERT_TRUE(slow.send("POST /v1/variant HTTP/1.1\r\nHost: x\r\nContent-Length: 100\r\n\r\n{\"pa"));
  Socket half(port);  // half a request line
  ASSERT_TRUE(half.send("POST /v1/var"));

  const std::string garbage = request("\x01\x02garbage\xff\xfe\r\n\r\n");  // dropped, or a 400
  EXPECT_TRUE(garbage.empty() || status_of(garbage).starts_with("HTTP/1.1 400")) << garbage;
  EXPECT_EQ(status_of(request("GET /v1/variant HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n")).substr(0, 12), "HTTP/1.1 405");
  EXPECT_EQ(status_of(request(post("{}", "/v1/other"))).substr(0, 12), "HTTP/1.1 404");
  EXPECT_EQ(status_of(request(post("{}", "/../../etc/passwd"))).substr(0, 12), "HTTP/1.1 404");
  EXPECT_EQ(status_of(request(post("not json"))).substr(0, 12), "HTTP/1.1 400");
  EXPECT_EQ(status_of(request(post("{\"pass\": \"P\xff\xfe\", \"keywords\": []}"))).substr(0, 12), "HTTP/1.1 400") << "invalid UTF-8";
  EXPECT_EQ(status_of(request(post(std::string(10000, '[') + std::string(10000, ']')))).substr(0, 12), "HTTP/1.1 400") << "deep";
  EXPECT_EQ(status_of(request(post(R"({"pass": "P", "keywords": ["A"], "then": 1})"))).substr(0, 12), "HTTP/1.1 400");
  EXPECT_EQ(status_of(request(post(R"({"pass": "P", "keywords": "A"})"))).substr(0, 12), "HTTP/1.1 400");
  EXPECT_EQ(status_of(request(post(R"({"pass": "P P", "keywords": []})"))).substr(0, 12), "HTTP/1.1 400");
  EXPECT_EQ(status_of(request(post(R"({"pass": ")" + std::string(300, 'P') + R"(", "keywords": []})"))).substr(0, 12), "HTTP/1.1 400");
  nlohmann::json many = nlohmann::json::array();
  for (int i = 0; i < 1000; ++i) many.push_back("K" + std::to_string(i));
  EXPECT_EQ(status_of(request(post(nlohmann::json{{"pass", "P"}, {"keywords", many}}.dump()))).substr(0, 12), "HTTP/1.1 400");
  // 10 MiB said up front: refused before it is read.
  EXPECT_EQ(status_of(request("POST /v1/variant HTTP/1.1\r\nHost: x\r\nConnection: close\r\nContent-Length: 10485760\r\n\r\n"))
                .substr(0, 12), "HTTP/1.1 413");
  {  // 10 MiB in chunks, which have no length to check first: read and dropped, then refused
    Socket socket(port);
    socket.send("POST /v1/variant HTTP/1.1\r\nHost: x\r\nConnection: close\r\nTransfer-Encoding: chunked\r\n\r\n");
    const std::string chunk(1 << 20, 'x');
    for (int i = 0; i < 10; ++i) socket.send("100000\r\n" + chunk + "\r\n");
    socket.send("0\r\n\r\n");
    EXPECT_EQ(status_of(socket.answer()).substr(0, 12), "HTTP/1.1 413");
  }
  // Headers over the connection's memory: refused by libmicrohttpd itself.
  const std::string huge_header = "POST /v1/variant HTTP/1.1\r\nHost: x\r\nX-Pad: " + std::string(200000, 'a') + "\r\n\r\n";
  Socket padded(port);
  padded.send(huge_header);
  EXPECT_FALSE(status_of(padded.answer()).starts_with("HTTP/1.1 200"));
  // Requests for what the pack cannot have: refused with the reader's words.
  std::string answer = request(post(R"({"pass": "Q", "keywords": []})"));
  EXPECT_EQ(status_of(answer).substr(0, 12), "HTTP/1.1 404") << answer;
  EXPECT_TRUE(contains(answer, "has no pass 'Q'")) << answer;
  answer = request(post(R"({"pass": "P", "keywords": ["A", "B"]})"));
  EXPECT_EQ(status_of(answer).substr(0, 12), "HTTP/1.1 400") << answer;
  answer = request(post(R"({"pass": "P", "keywords": ["C"]})"));
  EXPECT_EQ(status_of(answer).substr(0, 12), "HTTP/1.1 404") << answer;
  EXPECT_TRUE(contains(answer, "does not declare keyword 'C'")) << answer;

  // Still serving, with the slow clients' connections open: a good request is answered.
  answer = request(post(R"({"pass": "P", "keywords": ["A"]})"));
  EXPECT_EQ(status_of(answer), "HTTP/1.1 200 OK") << answer;
  EXPECT_TRUE(contains(answer, R"("archive":"p.)")) << answer;
  EXPECT_EQ(kiln->end(SIGTERM), 0);
}

// A client that sends half a request and stops is dropped by watch on its own (libmicrohttpd's 10 s connection
// timeout, which watch's poll() waits for as a deadline: with no other traffic, nothing else would wake it). The test
// waits for the close itself, an event; the receive timeout only ends a test that would otherwise hang.
TEST_F(DevelopmentEndpoint, AStalledClientIsDroppedWithoutAnyOtherTraffic) {
  start();
  Socket slow(port);
  ASSERT_TRUE(slow.send("POST /v1/variant HTTP/1.1\r\nHost: x\r\nContent-Length: 100\r\n\r\n{\"pa"));
  timeval limit{120, 0};
  ::setsockopt(slow.fd, SOL_SOCKET, SO_RCVTIMEO, &limit, sizeof limit);
  char byte = 0;
  errno = 0;
  const ssize_t n = ::recv(slow.fd, &byte, 1, 0);
  EXPECT_EQ(n, 0) << "the stalled connection was not closed by watch (errno " << errno << ")";
  EXPECT_EQ(kiln->end(SIGTERM), 0);
}

// Bounded over time (STYLE rule 19): a hundred requests, good and hostile, leave watch with the descriptors it had
// (a leaked connection or pack reader per request would be a hundred more).
TEST_F(DevelopmentEndpoint, DescriptorsStayFlatOverAHundredRequests) {
  start();
  EXPECT_EQ(status_of(request(post(R"({"pass": "P", "keywords": ["B"]})"))), "HTTP/1.1 200 OK");
  EXPECT_TRUE(contains(status(), "request P [B]: built into"));
  const size_t after_first = kiln->open_descriptors();
  for (int i = 0; i < 25; ++i) {
    EXPECT_EQ(status_of(request(post(R"({"pass": "P", "keywords": ["B"]})"))), "HTTP/1.1 200 OK");
    EXPECT_TRUE(contains(status(), "request P [B]: in p."));
    EXPECT_EQ(status_of(request(post(R"({"pass": "Q", "keywords": []})"))).substr(0, 12), "HTTP/1.1 404");
    EXPECT_TRUE(contains(status(), "request Q []: refused"));
    (void)request("\x16\x03\x01 not http at all\r\n\r\n");
    EXPECT_EQ(status_of(request(post("[[[[", "/v1/variant"))).substr(0, 12), "HTTP/1.1 400");
  }
  EXPECT_LE(kiln->open_descriptors(), after_first + 2) << "the last connections may still be closing";
  EXPECT_EQ(kiln->end(SIGTERM), 0);
}

// The same for reports (POST /v1/selected): good ones, from a hundred readers (more than watch keeps), and refused ones.
TEST_F(DevelopmentEndpoint, DescriptorsStayFlatOverAHundredReports) {
  start();
  EXPECT_EQ(status_of(request(post(R"({"client": "first", "selected": [{"pass": "P", "keywords": ["B"]}]})", "/v1/selected"))),
            "HTTP/1.1 200 OK");
  EXPECT_TRUE(contains(status(), "reader first: 1 variant selected, 1 new"));
  const size_t after_first = kiln->open_descriptors();
  for (int i = 0; i < 50; ++i) {
    const std::string report = R"({"client": "r)" + std::to_string(i) + R"(", "selected": [{"pass": "P", "keywords": []}]})";
    EXPECT_EQ(status_of(request(post(report, "/v1/selected"))), "HTTP/1.1 200 OK");
    EXPECT_TRUE(contains(status(), "reader r" + std::to_string(i) + ": 1 variant selected, 1 new"));
    EXPECT_EQ(status_of(request(post(R"({"client": "x", "selected": [[[[]]]]})", "/v1/selected"))).substr(0, 12), "HTTP/1.1 400");
  }
  EXPECT_LE(kiln->open_descriptors(), after_first + 2) << "the last connections may still be closing";
  EXPECT_EQ(kiln->end(SIGTERM), 0);
}

// Issue 61 item 1: what a connected reader selected is what the next round builds first. The log given to --usage
// does not exist (the game has not written one), so round 1 builds the full pack (there is no in-use set yet); the
// reader selects two of its three variants and reports them from its poll; after an edit, the round's pack (with
// --in-use-only, the only pack it builds) has exactly those two.
TEST_F(DevelopmentEndpoint, TheVariantsAReaderSelectedAreWhatTheNextRoundBuildsFirst) {
  start_with("usage/none.json", {"--in-use-only"}, "round 1: start; in use: no usage log yet; full: 3 variants");
  PackReader reader = PackReader::open(manifest());
  DevelopmentReader::Options options;
  options.report_interval = std::chrono::milliseconds(0);  // every poll looks at the log
  PackResult<DevelopmentReader> development = DevelopmentReader::open(reader, manifest(), options);
  ASSERT_TRUE(development) << development.message();
  ASSERT_TRUE(reader.try_select("P", {}));
  ASSERT_TRUE(reader.try_select("P", {"B", "NOT_DECLARED"}));  // a keyword the pass ignores: reported as [B]
  ASSERT_TRUE(development->poll_update());
  const std::string reported = status();
  EXPECT_TRUE(contains(reported, ": 2 variants selected, 2 new in the in-use set (2 selected)")) << reported << kiln->err();
  const std::string client = reported.substr(reported.find("reader ") + 7, reported.find(": 2 variants") - reported.find("reader ") - 7);
  // Selected again, and polled: nothing new, nothing sent (the next line is the round's, not a report's).
  ASSERT_TRUE(reader.try_select("P", {"B"}));
  ASSERT_TRUE(development->poll_update());
  ASSERT_TRUE(development->poll_update());
  dir.write("lib/Colour.hlsl", "float4 colour() { return 0.5; }\n");
  const std::string round = status();
  EXPECT_TRUE(contains(round, "round 2: ")) << round;
  EXPECT_TRUE(contains(round, "in use: 2 variants")) << round << kiln->err();
  EXPECT_FALSE(contains(round, "full:")) << round;
  PackReader built = PackReader::open(manifest());
  ASSERT_EQ(built.variant_count("P"), 2u);
  std::set<std::vector<std::string>> sets;
  for (size_t i = 0; i < 2; ++i) sets.insert(built.variant("P", i).keywords);
  EXPECT_EQ(sets, (std::set<std::vector<std::string>>{{}, {"B"}}));
  EXPECT_EQ(development->reported(), 2u);
  // The log the reports were read from is the development reader's own, and goes with it.
  const char* runtime = std::getenv("XDG_RUNTIME_DIR");
  const std::filesystem::path log = std::filesystem::path(runtime && *runtime ? runtime : std::filesystem::temp_directory_path().c_str()) /
                                    ("kiln-selected-" + client + ".usage.json");
  EXPECT_TRUE(std::filesystem::exists(log)) << log;
  { DevelopmentReader gone = std::move(*development); }
  EXPECT_FALSE(std::filesystem::exists(log)) << log;
  EXPECT_EQ(kiln->end(SIGTERM), 0);
}

// From C: kiln_development_poll_update reports what kiln_select_by_names served.
TEST_F(DevelopmentEndpoint, FromCThePollReportsTheSelectedVariants) {
  start_with("usage/none.json", {"--in-use-only"}, "round 1: start; in use: no usage log yet; full: 3 variants");
  kiln_pack* pack = nullptr;
  kiln_error error{};
  ASSERT_EQ(kiln_pack_open(manifest().c_str(), &pack, &error), KILN_OK) << error.message;
  kiln_development* development = nullptr;
  ASSERT_EQ(kiln_development_open(pack, manifest().c_str(), nullptr, &development, &error), KILN_OK) << error.message;
  const char* a[] = {"A"};
  uint32_t variant = 0;
  ASSERT_EQ(kiln_select_by_names(pack, "P", a, 1, 0, &variant, &error), KILN_OK) << error.message;
  kiln_pack_update update;
  ASSERT_EQ(kiln_development_poll_update(development, &update, &error), KILN_OK) << error.message;
  EXPECT_EQ(update.switched, 0);
  const std::string reported = status();
  EXPECT_TRUE(contains(reported, ": 1 variant selected, 1 new in the in-use set (1 selected)")) << reported;
  dir.write("lib/Colour.hlsl", "float4 colour() { return 0.5; }\n");
  EXPECT_TRUE(contains(status(), "in use: 1 variant")) << kiln->err();
  kiln_development_close(development);
  kiln_pack_close(pack);
  EXPECT_EQ(kiln->end(SIGTERM), 0);
}

// Reports are untrusted as requests are: the same checks on each variant, and bounds of their own. Each hostile one
// is refused; a report of what the pack cannot have is taken without adding anything; so the next round has no
// in-use set at all.
TEST_F(DevelopmentEndpoint, HostileReportsAreRefusedAndAddNothingToTheInUseSet) {
  start_with("usage/none.json", {"--in-use-only"}, "round 1: start; in use: no usage log yet; full: 3 variants");
  auto report = [&](const std::string& body) { return status_of(request(post(body, "/v1/selected"))).substr(0, 12); };
  EXPECT_EQ(report("not json"), "HTTP/1.1 400");
  EXPECT_EQ(report(std::string(10000, '[') + std::string(10000, ']')), "HTTP/1.1 400") << "deep";
  EXPECT_EQ(report(R"({"client": "c", "selected": [{"pass": "P", "keywords": [["A"]]}]})"), "HTTP/1.1 400") << "5 deep";
  EXPECT_EQ(report(R"({"selected": []})"), "HTTP/1.1 400") << "no client";
  EXPECT_EQ(report(R"({"client": "c d", "selected": []})"), "HTTP/1.1 400") << "a space in the id";
  EXPECT_EQ(report(R"({"client": ")" + std::string(65, 'c') + R"(", "selected": []})"), "HTTP/1.1 400") << "a long id";
  EXPECT_EQ(report(R"({"client": "c", "selected": [], "then": 1})"), "HTTP/1.1 400") << "unknown field";
  EXPECT_EQ(report(R"({"client": "c", "selected": {"pass": "P"}})"), "HTTP/1.1 400");
  EXPECT_EQ(report(R"({"client": "c", "selected": [{"pass": "P", "keywords": ["A"], "x": 1}]})"), "HTTP/1.1 400");
  EXPECT_EQ(report(R"({"client": "c", "selected": [{"pass": "P P", "keywords": []}]})"), "HTTP/1.1 400");
  EXPECT_EQ(report("{\"client\": \"c\", \"selected\": [{\"pass\": \"P\xff\", \"keywords\": []}]}"), "HTTP/1.1 400") << "UTF-8";
  nlohmann::json many = nlohmann::json::array();
  for (int i = 0; i < 65; ++i) many.push_back("K" + std::to_string(i));
  EXPECT_EQ(report(nlohmann::json{{"client", "c"}, {"selected", {{{"pass", "P"}, {"keywords", many}}}}}.dump()), "HTTP/1.1 400");
  nlohmann::json long_report = nlohmann::json::array();
  for (int i = 0; i < 257; ++i) long_report.push_back({{"pass", "P"}, {"keywords", nlohmann::json::array()}});
  EXPECT_EQ(report(nlohmann::json{{"client", "c"}, {"selected", long_report}}.dump()), "HTTP/1.1 400") << "257 variants";
  EXPECT_EQ(status_of(request("POST /v1/selected HTTP/1.1\r\nHost: x\r\nConnection: close\r\nContent-Length: 10485760\r\n\r\n"))
                .substr(0, 12), "HTTP/1.1 413");
  EXPECT_EQ(status_of(request("GET /v1/selected HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n")).substr(0, 12), "HTTP/1.1 405");
  // Well-formed, but nothing of this pack: an unknown pass, an undeclared keyword, two keywords of one group.
  const std::string answer = request(post(R"({"client": "c", "selected": [{"pass": "Q", "keywords": []},
      {"pass": "P", "keywords": ["C"]}, {"pass": "P", "keywords": ["A", "B"]}]})", "/v1/selected"));
  EXPECT_EQ(status_of(answer), "HTTP/1.1 200 OK") << answer;
  EXPECT_TRUE(contains(answer, R"("added":0)")) << answer;
  EXPECT_TRUE(contains(status(), "reader c: 3 variants selected, 0 new in the in-use set (0 selected; 3 not of this pack)"));
  dir.write("lib/Colour.hlsl", "float4 colour() { return 0.5; }\n");
  const std::string round = status();
  EXPECT_TRUE(contains(round, "round 2: ")) << round;
  EXPECT_TRUE(contains(round, "in use: no usage log yet")) << round;
  EXPECT_EQ(kiln->end(SIGTERM), 0);
}

// The in-use set is bounded: a reader's share, all readers' together, and the number of readers (a new one makes
// watch forget the one that reported least recently). A pass of 12 keyword groups declares 4,096 keyword sets, which
// the pack (narrowed to one by its usage log) lacks but could build, so watch takes each. K1803 says it once.
TEST_F(DevelopmentEndpoint, TheInUseSetIsBoundedPerReaderInAllAndInReaders) {
  std::string pragmas, body;
  for (int k = 0; k < 12; ++k) pragmas += "#pragma multi_compile _ K" + std::to_string(k) + "\n";
  dir.write("S.hlsl", pragmas + "float4 V(float4 p : POSITION) : SV_Position { return p; }\nfloat4 F() : SV_Target { return 1.0; }\n");
  dir.write("p.pack.json", R"({"name": "p", "budget": 8192,
    "passes": [{"name": "P", "source": "S.hlsl", "stages": {"vertex": "V", "fragment": "F"}}]})");
  dir.write("usage/run.json", usage_log({""}));
  start_with("usage/run.json", {"--in-use-only"}, "round 1: start; in use: 1 variant");
  auto keywords_of = [](int set) {
    nlohmann::json keywords = nlohmann::json::array();
    for (int k = 0; k < 12; ++k)
      if (set & (1 << k)) keywords.push_back("K" + std::to_string(k));
    return keywords;
  };
  auto report = [&](const std::string& client, int first) {  // 256 keyword sets from `first`
    nlohmann::json selected = nlohmann::json::array();
    for (int set = first; set < first + 256; ++set) selected.push_back({{"pass", "P"}, {"keywords", keywords_of(set)}});
    EXPECT_EQ(status_of(request(post(nlohmann::json{{"client", client}, {"selected", selected}}.dump(), "/v1/selected"))),
              "HTTP/1.1 200 OK");
    return status();
  };
  for (int part = 0; part < 4; ++part) EXPECT_TRUE(contains(report("r0", part * 256), "256 new")) << part;
  std::string line = report("r0", 1024);  // over one reader's 1,024
  EXPECT_TRUE(contains(line, "0 new in the in-use set (1024 selected; 256 over the bound)")) << line;
  for (int reader = 1; reader < 4; ++reader)
    for (int part = 0; part < 4; ++part) EXPECT_TRUE(contains(report("r" + std::to_string(reader), reader * 1024 + part * 256), "256 new"));
  line = report("r4", 0);  // over the 4,096 of all readers
  EXPECT_TRUE(contains(line, "0 new in the in-use set (4096 selected; 256 over the bound)")) << line;
  for (int reader = 5; reader < 16; ++reader) EXPECT_TRUE(contains(report("r" + std::to_string(reader), 0), "0 new"));
  line = report("r16", 0);  // a 17th reader: r0, which reported least recently, is forgotten
  EXPECT_TRUE(contains(line, "256 new in the in-use set (3328 selected)")) << line;
  EXPECT_EQ(kiln->end(SIGTERM), 0);
  const std::string err = kiln->err();
  EXPECT_TRUE(contains(err, "kiln: warning[K1803]: reader r0 selected more variants than the in-use set holds")) << err;
  EXPECT_EQ(err.find("K1803"), err.rfind("K1803")) << "once: " << err;
}

// watch's own errors are diagnostics of kiln's table: a port it cannot listen on is K1802, exit 3 (the machine's).
TEST_F(DevelopmentEndpoint, AnEndpointThatCannotListenIsK1802) {
  const int taken = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
  sockaddr_in address{};
  address.sin_family = AF_INET;
  address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  ASSERT_EQ(::bind(taken, reinterpret_cast<sockaddr*>(&address), sizeof address), 0);
  ASSERT_EQ(::listen(taken, 1), 0);
  socklen_t size = sizeof address;
  ::getsockname(taken, reinterpret_cast<sockaddr*>(&address), &size);
  const std::string endpoint = "127.0.0.1:" + std::to_string(ntohs(address.sin_port));
  testing::RunResult result = testing::run_kiln({"watch", "p.pack.json", "-o", "out", "--serve", endpoint}, dir.path());
  ::close(taken);
  EXPECT_EQ(result.exit_code, 3) << result.err;
  EXPECT_TRUE(contains(result.err, "kiln: error[K1802]: cannot listen on " + endpoint + ": ")) << result.err;
}

TEST_F(DevelopmentEndpoint, ServeRefusesAnAddressThatIsNotLoopback) {
  for (const char* address : {"0.0.0.0:0", "10.1.2.3:8080", "example.com:80", "[::]:0", "127.0.0.1:99999", "127.0.0.1"}) {
    testing::RunResult result = testing::run_kiln({"watch", "p.pack.json", "-o", "out", "--serve", address}, dir.path());
    EXPECT_EQ(result.exit_code, 1) << address;
    EXPECT_TRUE(contains(result.err, std::string("kiln: error: --serve '") + address + "': ")) << result.err;
  }
}

// A client answer is untrusted too: a server that answers with garbage, a 10 MiB body or an archive path gives the
// reader an error, never a crash or a switch.
TEST_F(DevelopmentEndpoint, TheClientRefusesHostileAnswers) {
  start();
  PackReader reader = PackReader::open(manifest());
  for (const std::string& body : {std::string("not json"), std::string(10 << 20, '{'),
                                  std::string(R"({"archive": "../../etc/passwd"})"), std::string(R"([1, 2])")}) {
    const int listener = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
    sockaddr_in address{};
    address.sin_family = AF_INET;
    address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    ASSERT_EQ(::bind(listener, reinterpret_cast<sockaddr*>(&address), sizeof address), 0);
    ASSERT_EQ(::listen(listener, 1), 0);
    socklen_t size = sizeof address;
    ::getsockname(listener, reinterpret_cast<sockaddr*>(&address), &size);
    const pid_t server = ::fork();
    if (server == 0) {  // one hostile answer to whatever comes
      const int connection = ::accept(listener, nullptr, nullptr);
      char buffer[4096];
      (void)::recv(connection, buffer, sizeof buffer, 0);
      const std::string answer = "HTTP/1.1 200 OK\r\nConnection: close\r\nContent-Length: " + std::to_string(body.size()) + "\r\n\r\n" + body;
      (void)::send(connection, answer.data(), answer.size(), MSG_NOSIGNAL);
      ::close(connection);
      ::_exit(0);
    }
    ::close(listener);
    DevelopmentReader::Options options;
    options.endpoint = "127.0.0.1:" + std::to_string(ntohs(address.sin_port));
    PackResult<DevelopmentReader> development = DevelopmentReader::open(reader, manifest(), options);
    ASSERT_TRUE(development);
    PackResult<SelectedVariant> selected = development->select_or_wait("P", {"B"}, std::chrono::seconds(120));
    EXPECT_FALSE(selected) << body.substr(0, 40);
    if (!selected) {
      EXPECT_TRUE(contains(selected.message(), "development endpoint: ")) << selected.message();
    }
    int status = 0;
    ::waitpid(server, &status, 0);
  }
  EXPECT_EQ(kiln->end(SIGTERM), 0);
}

// Release mode: a reader without a DevelopmentReader, or with from_environment() and the variable unset, connects to
// nothing, even for a variant the pack lacks, and even when the variable names a listening socket.
TEST_F(DevelopmentEndpoint, AReleaseReaderNeverConnects) {
  start();
  const int listener = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
  sockaddr_in address{};
  address.sin_family = AF_INET;
  address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  ASSERT_EQ(::bind(listener, reinterpret_cast<sockaddr*>(&address), sizeof address), 0);
  ASSERT_EQ(::listen(listener, 8), 0);
  socklen_t size = sizeof address;
  ::getsockname(listener, reinterpret_cast<sockaddr*>(&address), &size);
  const std::string endpoint = "127.0.0.1:" + std::to_string(ntohs(address.sin_port));
  dir.write("out/p.endpoint", endpoint + "\n");  // the endpoint file names the trap too

  PackReader reader = PackReader::open(manifest());
  EXPECT_FALSE(DevelopmentReader::from_environment(reader, manifest())) << "the variable is unset";
  ::setenv("KILN_DEVELOPMENT_ENDPOINT", endpoint.c_str(), 1);
  EXPECT_EQ(reader.try_select("P", {"B"}).code(), PackError::Code::Stripped);  // the release reader: no request
  ::unsetenv("KILN_DEVELOPMENT_ENDPOINT");
  pollfd entry{listener, POLLIN, 0};
  EXPECT_EQ(::poll(&entry, 1, 0), 0) << "a connection is waiting on the trap";

  // The same trap sees the development reader's request: the check above can fail.
  ::setenv("KILN_DEVELOPMENT_ENDPOINT", endpoint.c_str(), 1);
  auto development = DevelopmentReader::from_environment(reader, manifest());
  ::unsetenv("KILN_DEVELOPMENT_ENDPOINT");
  ASSERT_TRUE(development && *development);
  (void)(*development)->select_or_nearest("P", {"B"});
  EXPECT_EQ(::poll(&entry, 1, 120000), 1);
  const int connection = ::accept(listener, nullptr, nullptr);
  ::close(connection);  // the background request fails; the reader goes without waiting on it further
  ::close(listener);
  EXPECT_EQ(kiln->end(SIGTERM), 0);
}

}  // namespace
}  // namespace kiln
