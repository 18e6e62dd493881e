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

ResolvedInclude resolve_include(std::string_view name, const std::filesystem::path& including_file,
                                const IncludeRoots& roots) {
  ResolvedInclude result;
  std::filesystem::path requested{std::string(name)};
  if (name.empty()) {
    result.error = DiagId::IncludeSyntax;
    result.message = "empty #include file name";
    return result;
  }
  if (requested.is_absolute()) {
    result.error = DiagId::IncludeEscapesRoot;
    result.message = "absolute include path '" + std::string(name) + "' is not allowed; name files relative to an include root";
    return result;
  }
  std::vector<std::filesystem::path> directories{including_file.parent_path()};
  for (const auto& root : roots.roots()) directories.push_back(root);

  for (const auto& directory : directories) {
    std::filesystem::path lexical = (directory / requested).lexically_normal();
    // Leaving the roots through ".." is refused whether or not the file exists: no probing outside.
    if (!roots.contains(lexical)) {
      result.error = DiagId::IncludeEscapesRoot;
      result.message = "#include \"" + std::string(name) + "\" resolves to '" + lexical.string() +
                       "', outside the include roots";
      for (const auto& root : roots.roots()) result.notes.push_back("include root: " + display_path(root));
      return result;
    }
    std::error_code ec;
    if (!std::filesystem::exists(std::filesystem::symlink_status(lexical, ec))) {
      std::filesystem::path holder = lexical.parent_path();
      while (!std::filesystem::is_directory(holder, ec) && roots.contains(holder.parent_path())) holder = holder.parent_path();
      if (std::filesystem::is_directory(holder, ec) && roots.contains(holder)) result.watch.push_back(holder);
      continue;
    }
    std::filesystem::path canonical = std::filesystem::weakly_canonical(lexical, ec);
    if (ec) continue;
    if (!roots.contains(canonical)) {
      result.error = DiagId::IncludeEscapesRoot;
      result.message = "#include \"" + std::string(name) + "\" follows a symlink to '" + canonical.string() +
                       "', outside the include roots";
    } else {
      result.ok = true;
      result.path = canonical;
      return result;
    }
    for (const auto& root : roots.roots()) result.notes.push_back("include root: " + display_path(root));
    return result;
  }
  result.error = DiagId::IncludeNotFound;
  result.message = "cannot find include file '" + std::string(name) + "'";
  for (const auto& directory : directories) result.notes.push_back("searched: " + display_path(directory));
  return result;
}

}  // namespace kiln
