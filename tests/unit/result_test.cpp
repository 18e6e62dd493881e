// SPDX-License-Identifier: Apache-2.0
// kiln::Result, the library's one result type (kiln/result.hpp), and what returns it: the value or the error,
// never both; PackResult is one with the reader's error.
#include <gtest/gtest.h>

#include <filesystem>
#include <memory>

#include "common/files.hpp"
#include "common/hash.hpp"
#include "common/include_resolver.hpp"
#include "kiln/pack_reader.hpp"
#include "kiln/result.hpp"
#include "test_support.hpp"

namespace kiln {
namespace {

Result<int> half(int n) {
  if (n % 2) return failure(std::to_string(n) + " is odd");
  return n / 2;
}

TEST(Result, HoldsTheValueOrTheErrorNeverBoth) {
  Result<int> even = half(8);
  ASSERT_TRUE(even.has_value());
  EXPECT_EQ(*even, 4);
  Result<int> odd = half(7);
  ASSERT_FALSE(odd);
  EXPECT_EQ(odd.error().message, "7 is odd");

  // Move-only values move through; an error of any type, here a diagnostic.
  Result<std::unique_ptr<int>> owned = std::make_unique<int>(3);
  std::unique_ptr<int> taken = std::move(*owned);
  EXPECT_EQ(*taken, 3);
  Diagnostic diagnostic;
  diagnostic.id = DiagId::IncludeNotFound;
  diagnostic.message = "gone";
  diagnostic.notes = {"searched: x"};
  Result<int, Diagnostic> refused = failure(std::move(diagnostic));
  EXPECT_EQ(refused.error().id, DiagId::IncludeNotFound);
  EXPECT_EQ(refused.error().notes.at(0), "searched: x");

  Result<void> done;
  EXPECT_TRUE(done);
  Result<void> failed = failure("no");
  ASSERT_FALSE(failed);
  EXPECT_EQ(failed.error().message, "no");
}

TEST(Result, PackResultIsAResultWithThePackError) {
  const PackResult<int> failed(PackError::Code::Stripped, "no such variant", "p.manifest.json");
  const Result<int, PackError>& result = failed;  // the same type underneath
  ASSERT_FALSE(result);
  EXPECT_EQ(failed.code(), PackError::Code::Stripped);
  EXPECT_EQ(failed.message(), "no such variant");
  EXPECT_EQ(failed.file(), "p.manifest.json");
  EXPECT_EQ(result.error().code(), PackError::Code::Stripped);
  EXPECT_EQ(*PackResult<int>(5), 5);
}

TEST(Result, WritingAFileSaysWhichFileAndWhy) {
  testing::TempDir dir;
  EXPECT_TRUE(write_output_file(dir.path() / "a.txt", "text"));
  Result<void> failed = write_output_file(dir.path() / "missing" / "a.txt", "text");
  ASSERT_FALSE(failed);
  EXPECT_NE(failed.error().message.find("missing"), std::string::npos) << failed.error().message;
  EXPECT_NE(failed.error().message.find("No such file or directory"), std::string::npos) << failed.error().message;
}

// An archive is written as thousands of parts, more than one writev takes (IOV_MAX), some of them empty.
TEST(Result, AFileWrittenFromManyPartsHoldsThemJoined) {
  testing::TempDir dir;
  std::vector<std::string> texts;
  for (int i = 0; i < 3000; ++i) texts.push_back(i % 7 == 0 ? "" : std::string(static_cast<size_t>(i % 50), static_cast<char>('a' + i % 26)));
  std::vector<std::string_view> parts(texts.begin(), texts.end());
  std::string joined;
  for (std::string_view part : parts) joined += part;
  ASSERT_TRUE(write_output_file(dir.path() / "parts.bin", parts));
  EXPECT_EQ(*read_binary_file(dir.path() / "parts.bin"), joined);
  EXPECT_EQ(hash64(parts), hash64(joined));
  ASSERT_TRUE(write_output_file(dir.path() / "none.bin", std::vector<std::string_view>{}));
  EXPECT_EQ(*read_binary_file(dir.path() / "none.bin"), "");
}

TEST(Result, AnIncludeOutsideTheRootsIsTheDiagnosticToReport) {
  testing::TempDir dir;
  std::filesystem::create_directories(dir.path() / "root");
  const IncludeRoots roots({dir.path() / "root"});
  const std::filesystem::path including = std::filesystem::canonical(dir.path() / "root") / "a.hlsl";
  Result<ResolvedInclude, Diagnostic> escaped = resolve_include("../secret.hlsl", including, roots);
  ASSERT_FALSE(escaped);
  EXPECT_EQ(escaped.error().id, DiagId::IncludeEscapesRoot);
  EXPECT_FALSE(escaped.error().notes.empty());
  Result<ResolvedInclude, Diagnostic> missing = resolve_include("b.hlsl", including, roots);
  ASSERT_FALSE(missing);
  EXPECT_EQ(missing.error().id, DiagId::IncludeNotFound);
  dir.write("root/b.hlsl", "// b\n");
  Result<ResolvedInclude, Diagnostic> found = resolve_include("b.hlsl", including, roots);
  ASSERT_TRUE(found) << found.error().message;
  EXPECT_EQ(found->path.filename(), "b.hlsl");
}

}  // namespace
}  // namespace kiln
