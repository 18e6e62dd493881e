#include "common/include_resolver.hpp"

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
  for (const auto& directory : directories) searched.push_back("searched: " + display_path(directory));
  return refused(DiagId::IncludeNotFound, "cannot find include file '" + std::string(name) + "'", std::move(searched));
}

}  // namespace kiln
