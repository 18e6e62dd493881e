#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
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

With --decoys (unit.ci.InstallDepsAuditIgnoresWordsThatNameExecutables) the same checks run with a directory first
on PATH that holds an executable for every word of the scanned files that names no program here: a desktop has
`open` (xdg-utils) and /usr/local/bin may hold anything, and the scan must find the programs the scripts run, not
words that happen to name an executable on some machine.

usage: install_deps_test.py [--decoys] <kiln source dir>"""
import os
import re
import shutil
import subprocess
import sys
import tempfile

decoys = sys.argv[1] == "--decoys"
source = sys.argv[-1]
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


def first_words(code, names):
    """The first word of each command of shell `code` (quotes already blanked): after a separator (a newline, `;`,
    `&&`, `||`, `|`, a backquote, `$(`, a subshell's `(`), past keywords, assignments and `case` patterns."""
    code = re.sub(r"\$\(\((?:[^()]|\([^()]*\))*\)\)", "0", code)  # $(( arithmetic )): numbers and variables
    for segment in re.split(r"\|\||&&|[|;\n`]|\$\(|(?:^|(?<=[\s;&|]))\(", code):
        words = segment.split()
        if words and words[0] in ("for", "select", "case", "local", "declare", "readonly", "export"):
            continue  # `for api in gl gles`, `case $want in`, `local package=$1 depends`: names and words, no command
        while words and (words[0] in SHELL_KEYWORDS or re.match(r"^\w+=", words[0]) or words[0].endswith(")")):
            words.pop(0)
        if words and re.match(r"^[A-Za-z][\w.+-]*$", words[0]):
            names.add(words[0])


def blank_quotes(text, names):
    """`text` with what its quotes hold blanked: a quoted word is an argument, not a command. What runs inside them
    is scanned in its own language: `$(...)` in double quotes as shell, `bash -c '...'` as shell, `python3 -c '...'`
    as Python."""
    out, i = [], 0
    while i < len(text):
        c = text[i]
        if c == "\\":
            out.append(text[i:i + 2])
            i += 2
        elif c == "'":
            end = text.find("'", i + 1)
            end = len(text) if end < 0 else end
            before = "".join(out[-1:])[-40:] if out else ""
            before = "".join(out)[-40:]
            if re.search(r"\b(ba)?sh\s+-c\s*$", before):
                shell_commands(text[i + 1:end], names)
            elif re.search(r"\bpython3?\s+-c\s*$", before):
                names |= python_commands(text[i + 1:end])
            out.append("''")
            i = end + 1
        elif c == '"':
            j, inner = i + 1, []
            while j < len(text) and text[j] != '"':
                if text[j] == "\\":
                    j += 2
                    continue
                if text.startswith("$((", j):  # arithmetic: numbers and variables, no command
                    end = text.find("))", j)
                    j = len(text) if end < 0 else end + 2
                    continue
                if text.startswith("$(", j):  # a command substitution: its text is a command line of its own
                    depth, k = 1, j + 2
                    while k < len(text) and depth:
                        depth += {"(": 1, ")": -1}.get(text[k], 0)
                        k += 1
                    inner.append("\n" + text[j + 2:k - 1] + "\n")
                    j = k
                    continue
                j += 1
            out.append('""' + "".join(inner))
            i = j + 1
        else:
            out.append(c)
            i += 1
    return "".join(out)


def shell_commands(text, names=None):
    """The programs a shell script runs. A here-document is the input of the command before it: scanned as Python
    when that is python3, as shell when it is bash or sh, and otherwise not at all (text for cat, a file's body)."""
    names = set() if names is None else names
    lines, code, i = text.replace("\\\n", " ").split("\n"), [], 0
    while i < len(lines):
        line = re.sub(r"(^|\s)#.*", "", lines[i])
        code.append(line)
        i += 1
        heredoc = re.search(r"(?<!<)<<-?\s*(['\"]?)(\w+)\1", line)
        if not heredoc:
            continue
        body = []
        while i < len(lines) and lines[i].strip() != heredoc.group(2):
            body.append(lines[i])
            i += 1
        i += 1
        reader = line[:heredoc.start()]
        if re.search(r"\bpython3?\b", reader):
            names |= python_commands("\n".join(body))
        elif re.search(r"\b(ba)?sh\b", reader):
            shell_commands("\n".join(body), names)
    first_words(blank_quotes("\n".join(code), names), names)
    # The script's own functions (`fail() {`, `function render {`) run, but they are not programs.
    names -= set(re.findall(r"(?m)^\s*(?:function\s+)?([A-Za-z_][\w-]*)\s*(?:\(\s*\)|(?<=\w)\s+(?=\{))", text))
    return names


def python_commands(text):
    return set(re.findall(r"(?:run|call|check_output|check_call|Popen)\(\s*\[\s*[\"']([\w./+-]+)[\"']", text))


def cmake_commands(text):
    # A COMMAND that names one of the project's executables (`COMMAND kiln_capi_test`) runs what the build made, and
    # one that names an imported target (`Python3::Interpreter`) runs what find_package found.
    names = set(re.findall(r"\bCOMMAND\s+([A-Za-z/][\w./+-]*)(?![\w./+-]*::)", text)) - project_executables
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
if decoys:
    decoy_dir = tempfile.mkdtemp(prefix="kiln-decoys-")
    words = set()
    for relative in tracked:
        try:
            words |= set(re.findall(r"[A-Za-z][\w.+-]{0,31}", open(os.path.join(source, relative), encoding="utf-8",
                                                                    errors="replace").read()))
        except OSError:
            pass
    for word in words - set(audit):
        if shutil.which(word) is None:
            with open(os.path.join(decoy_dir, word), "w") as decoy:
                decoy.write("#!/bin/sh\nexit 0\n")
            os.chmod(os.path.join(decoy_dir, word), 0o755)
    os.environ["PATH"] = decoy_dir + os.pathsep + os.environ.get("PATH", "")
    print("%d decoy executables first on PATH" % len(os.listdir(decoy_dir)))

# The project's own executables, wherever a CMake file adds them (directly, or through kiln_add_test_suite).
project_executables = set()
for relative in tracked:
    if relative.endswith((".cmake", "CMakeLists.txt")):
        cmake_text = open(os.path.join(source, relative), encoding="utf-8", errors="replace").read()
        project_executables |= set(re.findall(r"\badd_executable\(\s*([\w.+-]+)", cmake_text))
        project_executables |= {"kiln_tests_" + kind for kind in re.findall(r"\bkiln_add_test_suite\(\s*(\w+)", cmake_text)}
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
if decoys:
    shutil.rmtree(decoy_dir, ignore_errors=True)
sys.exit(1 if failures else 0)
