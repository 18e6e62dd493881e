#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""Runs the sharding examples of docs/remote-cache.md (GitHub Actions matrix, GitLab `parallel:`, Kubernetes Indexed
Job) the way each scheduler would, against a real nginx on 127.0.0.1: every shard job's kiln command with the
variables that scheduler sets, then the merge job's command. Each example must compile every module exactly once
across its shards, and its merge must compile nothing and write the pack one machine writes. The YAML is parsed
(python3-yaml) and its shape checked: the shard count in the commands matches the matrix, `parallel:` or
`completions`, and the merge waits for the shards (`needs:`).

Only the pack is swapped (a small one instead of variants/lit.pack.json, which would cost a cold build per
example); every other argument is the documentation's.

usage: sharding_examples_test.py <kiln executable> <kiln source dir>"""
import json
import os
import re
import shlex
import shutil
import socket
import subprocess
import sys
import tempfile
import time

import yaml

kiln, source = os.path.abspath(sys.argv[1]), os.path.abspath(sys.argv[2])
failures = []


def check(condition, message):
    if not condition:
        failures.append(message)
    return condition


def yaml_blocks(markdown):
    return [yaml.safe_load(block) for block in re.findall(r"```yaml\n(.*?)```", markdown, re.S)]


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def start_nginx(work):
    port = free_port()
    server = os.path.join(work, "server")
    os.makedirs(os.path.join(server, "data"))
    os.makedirs(os.path.join(server, "tmp"))
    conf = os.path.join(server, "nginx.conf")
    with open(conf, "w") as f:
        f.write(f"""daemon off; master_process off; worker_processes 1; pid {server}/nginx.pid; error_log {server}/error.log;
events {{ worker_connections 128; }}
http {{ access_log {server}/access.log; client_body_temp_path {server}/tmp/body; proxy_temp_path {server}/tmp/proxy;
  fastcgi_temp_path {server}/tmp/fastcgi; uwsgi_temp_path {server}/tmp/uwsgi; scgi_temp_path {server}/tmp/scgi;
  client_max_body_size 64m;
  server {{ listen 127.0.0.1:{port}; root {server}/data;
    location / {{ dav_methods PUT; create_full_put_path on; dav_access user:rw; }} }} }}
""")
    proc = subprocess.Popen(["/usr/sbin/nginx", "-p", server + "/", "-c", conf, "-e", os.path.join(server, "error.log")])
    for _ in range(400):
        try:
            socket.create_connection(("127.0.0.1", port), timeout=0.2).close()
            return proc, f"http://127.0.0.1:{port}", os.path.join(server, "data")
        except OSError:
            if proc.poll() is not None:
                sys.exit("nginx exited: " + open(os.path.join(server, "error.log")).read())
            time.sleep(0.025)
    sys.exit("nginx did not start listening")


def write_checkout(directory):
    """A small library: 2 vertex and 4 fragment stage sources (the pack's name stays the examples')."""
    os.makedirs(os.path.join(directory, "variants"))
    with open(os.path.join(directory, "variants/S.hlsl"), "w") as f:
        f.write("#pragma multi_compile _ SHADOWS\n#pragma multi_compile_fragment _ FOG\n"
                "float4 V(float4 p : POSITION) : SV_Position { return p; }\n"
                "float4 F(float4 p : SV_Position) : SV_Target {\n  float c = 1.0;\n"
                "#ifdef SHADOWS\n  c *= saturate(p.x);\n#endif\n#ifdef FOG\n  c *= exp2(-p.y);\n#endif\n"
                "  return float4(c, c, c, 1.0);\n}\n")
    with open(os.path.join(directory, "variants/lit.pack.json"), "w") as f:
        json.dump({"name": "lit", "passes": [{"name": "P", "source": "S.hlsl", "stages": {"vertex": "V", "fragment": "F"}}]}, f)


def run_job(argv, cwd, env, what):
    """One job's kiln command: `argv` as the scheduler would start it (kiln from the build under test)."""
    assert argv[0] == "kiln", argv
    result = subprocess.run([kiln] + argv[1:], cwd=cwd, env=env, capture_output=True, text=True)
    check(result.returncode == 0, f"{what}: exit {result.returncode}: {result.stderr}")
    # "compiled N (back ends ...", or a shard's "shard I/N of ...: compiled N, M left to the other shards"
    match = re.search(r"compiled (\d+)", result.stdout)
    return int(match.group(1)) if match else None, result


def shell_words(command, env):
    """A `run:`/`script:` line as a POSIX shell would split it, with the variables of `env` expanded."""
    expanded = re.sub(r"\$\{?(\w+)\}?", lambda m: env.get(m.group(1), ""), command)
    return shlex.split(expanded)


with open(os.path.join(source, "docs/remote-cache.md"), encoding="utf-8") as f:
    docs = f.read()
examples = yaml_blocks(docs)
github = next((e for e in examples if isinstance(e, dict) and "jobs" in e), None)
gitlab = next((e for e in examples if isinstance(e, dict) and "shaders:shard" in e), None)
kubernetes = next((e for e in examples if isinstance(e, dict) and e.get("kind") == "Job"), None)
check(github and gitlab and kubernetes, "docs/remote-cache.md lacks one of the GitHub, GitLab and Kubernetes examples")

work = tempfile.mkdtemp(prefix="kiln-sharding-examples-")
nginx = None
try:
    nginx, url, server_data = start_nginx(work)
    base_env = {k: v for k, v in os.environ.items() if not k.startswith(("KILN_", "SLURM_", "CI_", "JOB_COMPLETION"))}

    # One machine, no remote: what every merge must reproduce.
    write_checkout(os.path.join(work, "alone"))
    alone_compiles, _ = run_job(["kiln", "build", "variants/lit.pack.json", "-o", "packs"], os.path.join(work, "alone"),
                                     base_env, "one machine")
    alone_pack = open(os.path.join(work, "alone/packs/lit.manifest.json"), "rb").read()

    def run_example(name, shards, merge):
        """`shards`: (argv, env) per shard job; `merge`: (argv, env). Each job in its own checkout and local cache; each
        example starts from an empty server."""
        shutil.rmtree(server_data)
        os.makedirs(server_data)
        total = 0
        for i, (argv, env) in enumerate(shards):
            checkout = os.path.join(work, f"{name}-shard{i}")
            write_checkout(checkout)
            counts, result = run_job(argv, checkout, env, f"{name} shard {i}")
            check(counts is not None, f"{name} shard {i}: no build summary: {result.stdout}")
            total += counts or 0
            # One after the other, each shard but the last finds another's bundle missing; the last assembles the pack.
            written = os.path.join(checkout, "packs/lit.manifest.json")
            if i + 1 < len(shards):
                check(not os.path.exists(written), f"{name} shard {i} wrote a pack")
            elif check(os.path.exists(written), f"{name}: the last shard did not assemble the pack: {result.stdout}"):
                check(open(written, "rb").read() == alone_pack, f"{name}: the last shard's manifest differs from one machine's")
        check(total == alone_compiles, f"{name}: the shards compiled {total} front ends, one machine {alone_compiles}")
        checkout = os.path.join(work, f"{name}-merge")
        write_checkout(checkout)
        counts, result = run_job(merge[0], checkout, merge[1], f"{name} merge")
        manifest = os.path.join(checkout, "packs/lit.manifest.json")
        if check(os.path.exists(manifest), f"{name} merge wrote no pack: {result.stdout}{result.stderr}"):
            check(open(manifest, "rb").read() == alone_pack, f"{name} merge: the manifest differs from one machine's")
        # The merge either fetched the finished pack or compiled nothing.
        check(counts is None or counts == 0, f"{name} merge compiled {counts}")
        # The merge uploaded the finished pack: a later reader of the commit fetches it whole (3 requests), not every
        # per-source entry.
        checkout = os.path.join(work, f"{name}-reader")
        write_checkout(checkout)
        _, result = run_job(["kiln", "build", "variants/lit.pack.json", "-o", "packs", "--remote", merge[1]["KILN_REMOTE"]],
                            checkout, base_env, f"{name} reader")
        check("fetched from the remote cache" in result.stdout,
              f"{name}: a reader after the merge did not fetch the finished pack: {result.stdout}")

    # GitHub Actions: a matrix of indices; `${{ matrix.index }}` and `/N` in the command; the token from secrets.
    if github:
        shard_job, merge_job = github["jobs"]["shard"], github["jobs"]["merge"]
        indices = shard_job["strategy"]["matrix"]["index"]
        check(indices == list(range(len(indices))), f"GitHub: matrix indices {indices} are not 0..N-1")
        check(merge_job.get("needs") == "shard", "GitHub: the merge job does not need the shard job")
        shard_run = next(s["run"] for s in shard_job["steps"] if "run" in s)
        check(f"/{len(indices)} " in shard_run, f"GitHub: the shard command's count is not the matrix's ({len(indices)})")
        env = dict(base_env, **{k: v for k, v in shard_job["env"].items() if not v.startswith("${{")})
        env["KILN_REMOTE"] = url
        shards = [(shell_words(shard_run.replace("${{ matrix.index }}", str(i)), env), env) for i in indices]
        merge_env = dict(base_env, KILN_REMOTE=url)
        run_example("github", shards, (shell_words(next(s["run"] for s in merge_job["steps"] if "run" in s), merge_env),
                                       merge_env))

    # GitLab CI: `parallel: N` sets CI_NODE_INDEX (1-based) and CI_NODE_TOTAL; KILN_REMOTE is a CI/CD variable.
    if gitlab:
        shard_job, merge_job = gitlab["shaders:shard"], gitlab["shaders:merge"]
        n = shard_job["parallel"]
        check(merge_job.get("needs") == ["shaders:shard"], "GitLab: the merge job does not need the shard job")
        shards = []
        for i in range(1, n + 1):
            env = dict(base_env, CI_NODE_INDEX=str(i), CI_NODE_TOTAL=str(n), KILN_REMOTE=url)
            shards.append((shell_words(shard_job["script"], env), env))
        merge_env = dict(base_env, KILN_REMOTE=url)
        run_example("gitlab", shards, (shell_words(merge_job["script"], merge_env), merge_env))

    # Kubernetes: an Indexed Job sets JOB_COMPLETION_INDEX; the spec's env gives KILN_SHARD_COUNT = completions.
    if kubernetes:
        spec = kubernetes["spec"]
        check(spec.get("completionMode") == "Indexed", "Kubernetes: the Job is not Indexed")
        container = spec["template"]["spec"]["containers"][0]
        spec_env = {e["name"]: e["value"] for e in container["env"]}
        check(spec_env.get("KILN_SHARD_COUNT") == str(spec["completions"]),
              "Kubernetes: KILN_SHARD_COUNT is not the Job's completions")
        shards = []
        for i in range(spec["completions"]):
            env = dict(base_env, **spec_env, JOB_COMPLETION_INDEX=str(i))
            env["KILN_REMOTE"] = url
            shards.append((list(container["command"]), env))
        merge_env = dict(base_env, KILN_REMOTE=url)
        # The merge Job, as the docs describe it: the shards' command without `--shard auto`, with `--remote-upload`.
        merge_argv = [a for a in container["command"] if a not in ("--shard", "auto")] + ["--remote-upload"]
        run_example("kubernetes", shards, (merge_argv, merge_env))
finally:
    if nginx:
        nginx.terminate()
        nginx.wait()
    shutil.rmtree(work, ignore_errors=True)

for f in failures:
    print("FAIL: " + f)
if failures:
    sys.exit(1)
print("the GitHub Actions, GitLab CI and Kubernetes sharding examples of docs/remote-cache.md work as written")
