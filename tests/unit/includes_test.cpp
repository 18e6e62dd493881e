// SPDX-License-Identifier: Apache-2.0
#include <gtest/gtest.h>
#include <sys/stat.h>


#include "declarations/declarations.hpp"
#include "common/include_resolver.hpp"
#include "test_support.hpp"

namespace kiln {
namespace {

struct ScanFixture : ::testing::Test {
  testing::TempDir dir;
  SourceSet sources;
  DiagnosticSink sink;
  std::optional<PassDeclarations> scan(const std::filesystem::path& entry) {
    IncludeRoots roots({dir / "root"});
    return scan_declarations(entry, roots, ReadLimits{}, sources, sink);
  }
  Diagnostic first() { return sink.diagnostics().at(0); }
};

TEST_F(ScanFixture, IncludeIsFoundNextToTheIncludingFileThenInTheRoots) {
  dir.write("root/sub/Near.hlsl", "float near;\n");
  dir.write("root/Far.hlsl", "float far;\n");
  auto entry = dir.write("root/sub/Main.hlsl", "#include \"Near.hlsl\"\n#include \"Far.hlsl\"\n");
  auto result = scan(entry);
  ASSERT_TRUE(result);
  EXPECT_EQ(result->files.size(), 3u);
}

TEST_F(ScanFixture, MissingIncludeListsTheDirectoriesSearched) {
  auto entry = dir.write("root/Main.hlsl", "\n  #include \"Nope.hlsl\"\n");
  EXPECT_FALSE(scan(entry));
  EXPECT_EQ(first().id, DiagId::IncludeNotFound);
  EXPECT_EQ(first().location.line, 2);
  EXPECT_EQ(first().location.column, 12);
  ASSERT_FALSE(first().notes.empty());
  EXPECT_NE(first().notes[0].find("searched:"), std::string::npos);
}

TEST_F(ScanFixture, DotDotThatLeavesTheRootIsRefused) {
  dir.write("secret.hlsl", "float secret;\n");
  auto entry = dir.write("root/Main.hlsl", "#include \"../secret.hlsl\"\n");
  EXPECT_FALSE(scan(entry));
  EXPECT_EQ(first().id, DiagId::IncludeEscapesRoot);
}

TEST_F(ScanFixture, AbsoluteIncludePathIsRefused) {
  auto entry = dir.write("root/Main.hlsl", "#include \"/etc/passwd\"\n");
  EXPECT_FALSE(scan(entry));
  EXPECT_EQ(first().id, DiagId::IncludeEscapesRoot);
}

TEST_F(ScanFixture, SymlinkOutOfTheRootIsRefused) {
  dir.write("outside.hlsl", "float outside;\n");
  std::filesystem::create_directories(dir / "root");
  std::filesystem::create_symlink(dir / "outside.hlsl", dir / "root/Link.hlsl");
  auto entry = dir.write("root/Main.hlsl", "#include \"Link.hlsl\"\n");
  EXPECT_FALSE(scan(entry));
  EXPECT_EQ(first().id, DiagId::IncludeEscapesRoot);
  EXPECT_NE(first().message.find("symlink"), std::string::npos);
}

TEST_F(ScanFixture, CycleIsReportedWithTheChain) {
  dir.write("root/A.hlsl", "#include \"B.hlsl\"\n");
  dir.write("root/B.hlsl", "#include \"A.hlsl\"\n");
  auto entry = dir.write("root/Main.hlsl", "#include \"A.hlsl\"\n");
  // No wall-clock bound (the suite runs on loaded machines): a followed cycle would not end, and
  // ctest's timeout fails that.
  EXPECT_FALSE(scan(entry));
  EXPECT_EQ(first().id, DiagId::IncludeCycle);
  ASSERT_GE(first().notes.size(), 2u);
  EXPECT_NE(first().notes[0].find("A.hlsl includes"), std::string::npos);
  EXPECT_NE(first().notes[1].find("B.hlsl includes"), std::string::npos);
}

TEST_F(ScanFixture, SelfIncludeIsACycle) {
  auto entry = dir.write("root/Main.hlsl", "#include \"Main.hlsl\"\n");
  EXPECT_FALSE(scan(entry));
  EXPECT_EQ(first().id, DiagId::IncludeCycle);
}

TEST_F(ScanFixture, GuardedMutualIncludesAreNotACycle) {
  dir.write("root/A.hlsl", "#ifndef A_INCLUDED\n#define A_INCLUDED\n#include \"B.hlsl\"\n#endif\n");
  dir.write("root/B.hlsl", "#pragma once\n#include \"A.hlsl\"\n");
  auto entry = dir.write("root/Main.hlsl", "#include \"A.hlsl\"\n");
  EXPECT_TRUE(scan(entry));
}

TEST_F(ScanFixture, IncludeOfADirectoryIsRefused) {
  std::filesystem::create_directories(dir / "root/Dir.hlsl");
  auto entry = dir.write("root/Main.hlsl", "#include \"Dir.hlsl\"\n");
  EXPECT_FALSE(scan(entry));
  EXPECT_EQ(first().id, DiagId::FileNotRegular);
  EXPECT_NE(first().message.find("a directory"), std::string::npos);
}

TEST_F(ScanFixture, IncludeOfAFifoIsRefusedWithoutBlocking) {
  std::filesystem::create_directories(dir / "root");
  ASSERT_EQ(::mkfifo((dir / "root/Fifo.hlsl").c_str(), 0644), 0);
  auto entry = dir.write("root/Main.hlsl", "#include \"Fifo.hlsl\"\n");
  EXPECT_FALSE(scan(entry));
  EXPECT_EQ(first().id, DiagId::FileNotRegular);
  EXPECT_NE(first().message.find("a FIFO"), std::string::npos);
}

TEST_F(ScanFixture, NulBytesAndInvalidUtf8AreNotText) {
  dir.write("root/Nul.hlsl", std::string("float a;\nfloat b\0;\n", 20));
  auto entry = dir.write("root/Main.hlsl", "#include \"Nul.hlsl\"\n");
  EXPECT_FALSE(scan(entry));
  EXPECT_EQ(first().id, DiagId::FileNotText);
  EXPECT_EQ(first().location.line, 2);
}

TEST_F(ScanFixture, Utf8ByteOrderMarkIsAccepted) {
  auto entry = dir.write("root/Main.hlsl", "\xEF\xBB\xBF#pragma multi_compile _ BOM_OK\n");
  auto result = scan(entry);
  ASSERT_TRUE(result);
  ASSERT_EQ(result->groups.size(), 1u);
  EXPECT_EQ(result->groups[0].declared_at.column, 1);
}

TEST_F(ScanFixture, FileOverTheSizeLimitIsRefused) {
  dir.write("root/Big.hlsl", std::string(64, 'x'));
  auto entry = dir.write("root/Main.hlsl", "#include \"Big.hlsl\"\n");
  IncludeRoots roots({dir / "root"});
  EXPECT_FALSE(scan_declarations(entry, roots, ReadLimits{32}, sources, sink));
  EXPECT_EQ(first().id, DiagId::FileTooLarge);
}

}  // namespace
}  // namespace kiln
