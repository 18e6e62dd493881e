// SPDX-License-Identifier: Apache-2.0
#include "common/include_resolver.hpp"

#include <algorithm>
#include <cctype>
#include <optional>
#include <system_error>

namespace kiln {
namespace {

bool is_below(const std::filesystem::path& path, const std::filesystem::path& root) {
  auto p = path.begin();
  for (auto r = root.begin(); r != root.end(); ++r, ++p) {
    if (r->empty()) continue;  // trailing separator
    if (p == path.end() || *p != *r) return false;
  }
  return true;
}

std::string lower(std::string text) {
  for (char& c : text) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return text;
}

// The file under `directory` that `name` names when case and slash direction are ignored (`Common\\lighting.HLSLI`
// for `Common/Lighting.hlsli`), as the name to write; nothing when there is none, or more than one. Each component
// lists one directory, bounded (a hint is not worth a scan of a huge folder).
std::optional<std::string> differently_spelled(std::string_view name, const std::filesystem::path& directory, const IncludeRoots& roots) {
  constexpr size_t kMaxEntries = 4096, kMaxComponents = 32;
  std::string forward(name);
  std::replace(forward.begin(), forward.end(), '\\', '/');
  std::filesystem::path at = directory;
  std::string spelled;
  size_t components = 0;
  for (const auto& component : std::filesystem::path(forward).lexically_normal()) {
    if (++components > kMaxComponents) return std::nullopt;
    const std::string part = component.string();
    if (part.empty() || part == ".") continue;
    std::filesystem::path next;
    if (part == "..") {
      next = at.parent_path();
    } else {
      std::error_code ec;
      std::filesystem::directory_iterator entries(at, ec), end;
      size_t seen = 0, matches = 0;
      for (; !ec && entries != end && seen < kMaxEntries; entries.increment(ec), ++seen) {
        const std::string entry = entries->path().filename().string();
        if (lower(entry) == lower(part)) {
          next = entries->path();
          ++matches;
        }
      }
      if (matches != 1) return std::nullopt;
    }
    spelled += (spelled.empty() ? "" : "/") + (part == ".." ? part : next.filename().string());
    at = next;
  }
  std::error_code ec;
  if (spelled.empty() || spelled == name || !std::filesystem::is_regular_file(at, ec) || !roots.contains(at.lexically_normal()))
    return std::nullopt;
  return spelled;
}

}  // namespace

IncludeRoots::IncludeRoots(const std::vector<std::filesystem::path>& roots) {
  for (const auto& root : roots) {
    std::error_code ec;
    auto canonical = std::filesystem::weakly_canonical(root, ec);
    if (!ec) roots_.push_back(canonical);
  }
}

bool IncludeRoots::contains(const std::filesystem::path& canonical) const {
  for (const auto& root : roots_)
    if (is_below(canonical, root)) return true;
  return false;
}

Result<ResolvedInclude, Diagnostic> resolve_include(std::string_view name, const std::filesystem::path& including_file,
                                                    const IncludeRoots& roots) {
  auto refused = [&](DiagId id, std::string message, std::vector<std::string> notes = {}) {
    Diagnostic diagnostic;
    diagnostic.id = id;
    diagnostic.message = std::move(message);
    diagnostic.notes = std::move(notes);
    return failure(std::move(diagnostic));
  };
  auto root_notes = [&] {
    std::vector<std::string> notes;
    for (const auto& root : roots.roots()) notes.push_back("include root: " + display_path(root));
    return notes;
  };
  std::filesystem::path requested{std::string(name)};
  if (name.empty()) return refused(DiagId::IncludeSyntax, "empty #include file name");
  if (requested.is_absolute())
    return refused(DiagId::IncludeEscapesRoot,
                   "absolute include path '" + std::string(name) + "' is not allowed; name files relative to an include root");
  std::vector<std::filesystem::path> directories{including_file.parent_path()};
  for (const auto& root : roots.roots()) directories.push_back(root);

  ResolvedInclude result;
  for (const auto& directory : directories) {
    std::filesystem::path lexical = (directory / requested).lexically_normal();
    // Leaving the roots through ".." is refused whether or not the file exists: no probing outside.
    if (!roots.contains(lexical))
      return refused(DiagId::IncludeEscapesRoot,
                     "#include \"" + std::string(name) + "\" resolves to '" + lexical.string() + "', outside the include roots",
                     root_notes());
    std::error_code ec;
    if (!std::filesystem::exists(std::filesystem::symlink_status(lexical, ec))) {
      std::filesystem::path holder = lexical.parent_path();
      while (!std::filesystem::is_directory(holder, ec) && roots.contains(holder.parent_path())) holder = holder.parent_path();
      if (std::filesystem::is_directory(holder, ec) && roots.contains(holder)) result.watch.push_back(holder);
      continue;
    }
    std::filesystem::path canonical = std::filesystem::weakly_canonical(lexical, ec);
    if (ec) continue;
    if (!roots.contains(canonical))
      return refused(DiagId::IncludeEscapesRoot,
                     "#include \"" + std::string(name) + "\" follows a symlink to '" + canonical.string() +
                         "', outside the include roots",
                     root_notes());
    result.path = canonical;
    return result;
  }
  std::vector<std::string> searched;
  for (const auto& directory : directories) {
    if (auto spelled = differently_spelled(name, directory, roots)) {
      // Include names are case-sensitive and use '/' here, as on every system but Windows (where DXC users wrote them).
      searched.insert(searched.begin(), "a file differs only in case or slash direction: #include \"" + *spelled + "\" (" +
                                            display_path(directory / *spelled) + ")");
      break;
    }
  }
  for (const auto& directory : directories) searched.push_back("searched: " + display_path(directory));
  return refused(DiagId::IncludeNotFound, "cannot find include file '" + std::string(name) + "'", std::move(searched));
}

}  // namespace kiln
