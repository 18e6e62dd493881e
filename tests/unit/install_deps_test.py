#!/usr/bin/env python3
"""unit.ci.InstallDepsCoverEveryProgram: every program the build and the suite run comes from a package that
.ci/install-deps installs, so a fresh Debian 12 has it (cpack's DEB generator needed `file`, which only the
development machines happened to have).

Two checks, both against .ci/install-deps alone:
 1. The audit (the `#   program  package  who` rows in .ci/install-deps): each program is installed here, dpkg -S
    says it comes from the package the row names, and that package is in the install list, or is installed by one
    in it (its Depends, recursively), or is one of Debian's `required` packages, which every Debian 12 has.
 2. The scan: every program the test scripts, the CMake files and the C++ tests name in a command position (a
    shell command, a Python subprocess list, a CMake COMMAND or find_program, an absolute /usr path in C++) is
    either in the audit or comes from a `required` package. A new test that runs a new program fails here, on the
    development machine, until the program has its row and its package.

usage: install_deps_test.py <kiln source dir>"""
import os
import re
import shutil
import subprocess
import sys

source = sys.argv[1]
failures = []
install_deps = open(os.path.join(source, ".ci/install-deps"), encoding="utf-8").read()

# The install list: the words inside `packages=( ... )`, comments removed.
block = re.search(r"^packages=\((.*?)^\)", install_deps, re.S | re.M).group(1)
packages = set(re.sub(r"#.*", "", block).split())
# The audit: rows "#   <program>  <package>  <who runs it>" after the "program  package" header.
audit_text = install_deps.split("#   program", 1)[-1]
audit = {}
for line in audit_text.splitlines()[1:]:
    row = re.match(r"#   (\S+)\s+(\S+)\s+\S", line)
    if not row:
        break
    audit[row.group(1)] = row.group(2)
if len(audit) < 20:
    failures.append("the audit in .ci/install-deps has %d rows; expected the whole list" % len(audit))


# What dpkg -S answers, for every installed file at once: dpkg's own file lists (one dpkg -S per program costs
# seconds). Debian 12 merges /bin into /usr/bin, and its packages still list /bin/cat: both spellings are keys.
owners = {}
info = "/var/lib/dpkg/info"
for name in os.listdir(info):
    if name.endswith(".list"):
        package = name[:-len(".list")].split(":")[0]
        with open(os.path.join(info, name), encoding="utf-8", errors="replace") as listing:
            for line in listing:
                owners.setdefault(line.rstrip("\n"), package)


def dpkg_owner(path):
    """The package that installed `path` (or the file it links to), or None."""
    for candidate in (path, os.path.realpath(path)):
        for spelling in (candidate, re.sub(r"^/usr/(s?bin)/", r"/\1/", candidate)):
            if spelling in owners:
                return owners[spelling]
    return None


def debian_which(program):
    """Where a Debian package put `program`: PATH may put something else first (a pyenv python3 here)."""
    if program.startswith("/"):
        return program if os.path.exists(program) else None
    for directory in ("/usr/bin", "/usr/sbin", "/bin", "/sbin"):
        path = os.path.join(directory, program)
        if os.path.exists(path) and dpkg_owner(path):
            return path
    return shutil.which(program)


def priority(package):
    result = subprocess.run(["dpkg-query", "-W", "-f=${Priority} ${Essential}", package], capture_output=True, text=True)
    return result.stdout.split() if result.returncode == 0 else []


def is_base(package):
    """Every Debian 12, minimal or not, has the `required` and Essential packages."""
    fields = priority(package)
    return "required" in fields or "yes" in fields


# Everything apt installs for the install list: the list and its Depends/Pre-Depends, recursively, as the installed
# packages state them (dpkg's database: no package lists needed). Every alternative of an `a | b` counts, and a
# virtual package leads to the packages that provide it.
depends, provided_by = {}, {}
installed = subprocess.run(["dpkg-query", "-W", "-f=${Package}\t${Depends}, ${Pre-Depends}\t${Provides}\n"],
                           capture_output=True, text=True).stdout
for line in installed.splitlines():
    name, requires, provides = (line.split("\t") + ["", ""])[:3]
    depends[name] = re.findall(r"(?:^|[,|]\s*)([a-z0-9][\w.+-]*)", requires)
    for virtual in re.findall(r"(?:^|,\s*)([a-z0-9][\w.+-]*)", provides):
        provided_by.setdefault(virtual, []).append(name)
closure, pending = set(), list(packages)
while pending:
    package = pending.pop()
    if package in closure:
        continue
    closure.add(package)
    pending += depends.get(package, []) + provided_by.get(package, [])

# 1. The audit's rows.
for program, package in sorted(audit.items()):
    path = debian_which(program)
    if path is None:
        failures.append("%s (audit row for package %s) is not installed on this machine" % (program, package))
        continue
    owner = dpkg_owner(path)
    if owner != package:
        failures.append("%s is %s, which dpkg -S says comes from %s, not %s" % (program, path, owner, package))
    if package not in closure and not is_base(package):
        failures.append("%s comes from %s, which .ci/install-deps neither installs nor gets through a dependency"
                        % (program, package))

# 2. The scan of what the suite runs.
SHELL_KEYWORDS = {"if", "then", "else", "elif", "fi", "for", "while", "until", "do", "done", "case", "esac", "in",
                  "function", "time", "exec", "command", "!", "{", "}", "[[", "]]", "local", "export", "return"}


def shell_commands(text):
    names = set()
    for line in text.splitlines():
        line = re.sub(r"(^|\s)#.*", "", line)
        for segment in re.split(r"\|\||&&|[|;({`]|\$\(", line):
            words = segment.split()
            while words and (words[0] in SHELL_KEYWORDS or re.match(r"^\w+=", words[0])):
                words.pop(0)
            if words and re.match(r"^[A-Za-z][\w.+-]*$", words[0]):
                names.add(words[0])
    return names


def python_commands(text):
    return set(re.findall(r"(?:run|call|check_output|check_call|Popen)\(\s*\[\s*[\"']([\w./+-]+)[\"']", text))


def cmake_commands(text):
    names = set(re.findall(r"\bCOMMAND\s+([A-Za-z/][\w./+-]*)", text))
    names |= set(re.findall(r"find_program\(\s*\w+\s+(?:NAMES\s+)?([A-Za-z][\w.+-]*)", text))
    return names


def cpp_commands(text):
    return set(re.findall(r"\"(/usr/s?bin/[\w.+-]+)\"", text))


tracked = subprocess.run(["git", "-C", source, "ls-files", "tests", "examples", "cmake", "verify", "CMakeLists.txt",
                          "compiler/CMakeLists.txt", ".ci"], capture_output=True, text=True).stdout.split()
if not tracked:  # a source tree without git (an unpacked archive): walk it instead
    for top in ("tests", "examples", "cmake", "verify"):
        for directory, _, files in os.walk(os.path.join(source, top)):
            tracked += [os.path.relpath(os.path.join(directory, f), source) for f in files]
# Run by hand, outside the README's suite (label chroot, which the presets leave out): it needs debootstrap and
# says so itself, and the programs inside its chroot come from the README's own install step.
OUTSIDE_THE_SUITE = {"tests/package/fresh_debian_test.sh"}
found = {}
for relative in tracked:
    if "/corpus/" in relative or "/fuzz/corpus" in relative or relative in OUTSIDE_THE_SUITE:
        continue
    path = os.path.join(source, relative)
    try:
        text = open(path, encoding="utf-8", errors="replace").read()
    except OSError:
        continue
    if relative == ".ci/install-deps":
        continue  # its package list is not a list of commands
    if relative.endswith(".sh") or relative.startswith(".ci/"):
        names = shell_commands(text)
    elif relative.endswith(".py"):
        names = python_commands(text)
    elif relative.endswith((".cmake", "CMakeLists.txt")):
        names = cmake_commands(text)
    elif relative.endswith((".cpp", ".hpp")):
        names = cpp_commands(text)
    else:
        continue
    for name in names:
        found.setdefault(name, set()).add(relative)

audited_paths = {os.path.realpath(debian_which(p)) for p in audit if debian_which(p)}
for name, where in sorted(found.items()):
    path = debian_which(name)
    if path is None or not os.path.exists(path):
        continue  # a shell function, a builtin or a variable's value: not a program
    kind = subprocess.run(["bash", "-c", 'type -t "$1"', "_", name], capture_output=True, text=True).stdout.strip()
    if kind in ("builtin", "keyword"):
        continue
    if os.path.basename(name) in audit or os.path.realpath(path) in audited_paths:
        continue
    owner = dpkg_owner(path)
    if owner is not None and is_base(owner):
        continue
    failures.append("%s runs %s (%s, package %s), which the audit in .ci/install-deps does not list"
                    % (", ".join(sorted(where)), name, path, owner))

for failure in failures:
    print("FAIL:", failure)
print("%d audited programs, %d programs named by the suite's files, %d packages installed: %d failure(s)"
      % (len(audit), len(found), len(packages), len(failures)))
sys.exit(1 if failures else 0)
