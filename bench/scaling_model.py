#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""How kiln's cold build would scale: more cores, and more machines through the remote cache (issue 26 item 6,
issue 24 section 4).

Measured here, interleaved:
  * the library floor with each job's time (kiln-compile-steps --floor: every distinct stage source's front end,
    every distinct module's back end, one after the other in one process);
  * cold builds of the pack at -j1 and -j2, with kiln's stage times (--summary-json) and their CPU time;
  * with --shards: nginx on 127.0.0.1 as the remote cache, N = 1, 2, 4 shards (`--shard I/N`) run side by side on
    this machine, then the merge build (a build against the filled remote that compiles nothing).

The model (no fitted curve: every term is a measurement or a schedule of measured jobs):
  T(P) = serial + preprocess(1)/P + makespan(P)
  * makespan(P): kiln's schedule simulated on P workers: one FIFO queue, front ends in build order, each back end
    queued when its front end ends (compiler/src/workers/worker_pool.cpp), each job's floor time plus a per-job
    overhead (messages, compression, process) calibrated so that the model equals the measured -j1 compile stage;
  * preprocess(1): the -j1 build's preprocessing stage (the workers preprocess; it divides by P);
  * serial: the rest of the -j1 build (planning, dedupe, cache store, layouts, pack): the part no core count shortens.
  The -j2 build checks it (the model is calibrated on -j1 only). A farm of M machines with C cores each:
  T = max over shards(serial_shard + preprocess(1)/C + makespan of its share on C) + merge; every shard plans and
  preprocesses the whole pack (the keys come from the text), and the merge is measured.

usage: python3 bench/scaling_model.py --kiln build/ci/compiler/kiln --floor-tool build/ci/bench/kiln-compile-steps
                                      [--pack variants/lit.pack.json] [--reps 3] [--shards]
                                      [--out bench/results/scaling_model.json]
"""
import argparse
import hashlib
import heapq
import json
import os
import resource
import shutil
import socket
import statistics
import subprocess
import sys
import tempfile
import time
from collections import deque

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def run(cmd, **kw):
    """Runs cmd; returns (wall seconds, CPU seconds of the process tree, stdout)."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    proc = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, **kw)
    wall = time.perf_counter() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if proc.returncode != 0:
        sys.exit(f"command failed ({proc.returncode}): {cmd}\n{proc.stderr[-3000:]}")
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return wall, cpu, proc.stdout


def loadavg():
    return open("/proc/loadavg").read().split()[0]


def makespan(jobs, workers, overhead_ms):
    """kiln's FIFO schedule of (front end ms, back end ms) jobs on `workers`; back end 0 = module shared."""
    queue = deque(("front", i) for i in range(len(jobs)))
    running = []  # (finish, sequence, kind, index)
    now = 0.0
    sequence = 0
    end = 0.0

    def start(at):
        nonlocal sequence
        kind, i = queue.popleft()
        cost = (jobs[i][0] if kind == "front" else jobs[i][1]) + overhead_ms
        heapq.heappush(running, (at + cost, sequence, kind, i))
        sequence += 1

    while queue and len(running) < workers:
        start(0.0)
    while running:
        now, _, kind, i = heapq.heappop(running)
        end = max(end, now)
        if kind == "front" and jobs[i][1] > 0:
            queue.append(("back", i))
        while queue and len(running) < workers:
            start(now)
    return end / 1000.0


def stage_ms(summary, name):
    return sum(t["milliseconds"] for t in summary["timings"] if t["stage"] == name)


class Nginx:
    """nginx with WebDAV PUT on 127.0.0.1, in the foreground, stopped by its PID (as the tests run it)."""

    def __init__(self, work):
        self.dir = os.path.join(work, "server")
        os.makedirs(os.path.join(self.dir, "tmp"), exist_ok=True)
        s = socket.socket()
        s.bind(("127.0.0.1", 0))
        self.port = s.getsockname()[1]
        s.close()
        d = self.dir
        with open(os.path.join(d, "nginx.conf"), "w") as f:
            f.write(f"""daemon off; master_process off; worker_processes 1; pid {d}/nginx.pid; error_log {d}/error.log;
events {{ worker_connections 256; }}
http {{ access_log off; client_body_temp_path {d}/tmp/body; proxy_temp_path {d}/tmp/proxy;
  fastcgi_temp_path {d}/tmp/fastcgi; uwsgi_temp_path {d}/tmp/uwsgi; scgi_temp_path {d}/tmp/scgi;
  client_max_body_size 512m;
  server {{ listen 127.0.0.1:{self.port}; root {d}/data;
    location / {{ dav_methods PUT; create_full_put_path on; dav_access user:rw; }} }} }}
""")
        self.clear()
        self.proc = subprocess.Popen(["/usr/sbin/nginx", "-p", d + "/", "-c", os.path.join(d, "nginx.conf"), "-e",
                                      os.path.join(d, "error.log")])
        for _ in range(400):
            try:
                socket.create_connection(("127.0.0.1", self.port), timeout=1).close()
                return
            except OSError:
                time.sleep(0.025)
        sys.exit("nginx did not start")

    def url(self):
        return f"http://127.0.0.1:{self.port}"

    def clear(self):
        shutil.rmtree(os.path.join(self.dir, "data"), ignore_errors=True)
        os.makedirs(os.path.join(self.dir, "data"))

    def stop(self):
        self.proc.terminate()
        self.proc.wait()


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--kiln", required=True)
    parser.add_argument("--floor-tool", required=True)
    parser.add_argument("--pack", default=os.path.join(ROOT, "variants/lit.pack.json"))
    parser.add_argument("--reps", type=int, default=3)
    parser.add_argument("--shards", action="store_true", help="also measure N = 1, 2, 4 shards and the merge")
    parser.add_argument("--out", default=os.path.join(ROOT, "bench/results/scaling_model.json"))
    args = parser.parse_args()
    kiln = os.path.abspath(args.kiln)
    work = tempfile.mkdtemp(prefix="kiln-scaling-model-")
    loads = [loadavg()]
    try:
        # The floor, job by job, on the stage sources a cold build compiles.
        run([kiln, "build", args.pack, "-o", os.path.join(work, "emit"), "--cache", os.path.join(work, "cache-emit"), "-q",
             "--emit", "preprocessed"])
        floor_json = os.path.join(work, "floor.json")
        run([os.path.abspath(args.floor_tool), "--floor", os.path.join(work, "emit", "emit"), args.pack, "--json", floor_json])
        floor = json.load(open(floor_json))
        jobs = [(j["front_end_ms"], j["back_end_ms"]) for j in floor["jobs"]]
        loads.append(loadavg())

        def cold(jobs_flag, tag):
            out, cache = os.path.join(work, f"out-{tag}"), os.path.join(work, f"cache-{tag}")
            summary = os.path.join(work, f"summary-{tag}.json")
            for d in (out, cache):
                shutil.rmtree(d, ignore_errors=True)
            wall, cpu, _ = run([kiln, "build", args.pack, "-o", out, "--cache", cache, "-j", str(jobs_flag), "-q",
                                "--summary-json", summary])
            s = json.load(open(summary))
            return {"wall_s": wall, "cpu_s": cpu, "total_s": stage_ms(s, "total") / 1000,
                    "preprocess_s": stage_ms(s, "preprocess") / 1000, "compile_s": stage_ms(s, "compile") / 1000,
                    "compiled": s["compiled"], "back_ends": s["back_ends"]}

        builds = {1: [], 2: []}
        for rep in range(args.reps):
            for j in (1, 2):
                builds[j].append(cold(j, f"j{j}-{rep}"))
                loads.append(loadavg())

        def median(j, key):
            return statistics.median(b[key] for b in builds[j])

        floor_front = sum(f for f, _ in jobs) / 1000
        floor_back = sum(b for _, b in jobs) / 1000
        n_jobs = len(jobs) + sum(1 for _, b in jobs if b > 0)
        # Calibration on -j1 only.
        compile1, preprocess1, total1 = median(1, "compile_s"), median(1, "preprocess_s"), median(1, "total_s")
        overhead_ms = max(0.0, (compile1 - floor_front - floor_back) * 1000 / n_jobs)
        serial = total1 - compile1 - preprocess1

        def model(cores):
            return serial + preprocess1 / cores + makespan(jobs, cores, overhead_ms)

        cores_table = [{"cores": c, "model_s": model(c), "makespan_s": makespan(jobs, c, overhead_ms),
                        "work_over_cores_s": (floor_front + floor_back + n_jobs * overhead_ms / 1000) / c}
                       for c in (1, 2, 4, 8, 16, 64)]
        longest_job_s = max(max(f, b) for f, b in jobs) / 1000 + overhead_ms / 1000

        shards = {}
        if args.shards:
            server = Nginx(work)
            try:
                for rep in range(args.reps):
                    for n in (1, 2, 4):
                        server.clear()
                        per_shard_jobs = max(1, 2 // n)
                        procs, start = [], time.perf_counter()
                        before = resource.getrusage(resource.RUSAGE_CHILDREN)
                        for i in range(n):
                            out, cache = os.path.join(work, f"shard-{n}-{i}-{rep}"), os.path.join(work, f"cache-shard-{n}-{i}-{rep}")
                            procs.append(subprocess.Popen(
                                [kiln, "build", args.pack, "-o", out, "--cache", cache, "-j", str(per_shard_jobs),
                                 "--remote", server.url(), "--shard", f"{i}/{n}"],
                                stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True))
                        lines = []
                        for p in procs:
                            o, e = p.communicate()
                            if p.returncode != 0:
                                sys.exit(f"shard failed: {e[-2000:]}")
                            lines.append(o.splitlines()[0])
                        shard_wall = time.perf_counter() - start
                        after = resource.getrusage(resource.RUSAGE_CHILDREN)
                        shard_cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
                        merge_out = os.path.join(work, f"merge-{n}-{rep}")
                        merge_wall, merge_cpu, merge_stdout = run(
                            [kiln, "build", args.pack, "-o", merge_out, "--cache", os.path.join(work, f"cache-merge-{n}-{rep}"),
                             "--remote", server.url()])
                        # With one shard, that shard wrote the pack and its pack-level entry: the merge fetches it.
                        if "compiled 0 " not in merge_stdout and "fetched from the remote cache" not in merge_stdout:
                            sys.exit("the merge compiled something:\n" + merge_stdout)
                        shards.setdefault(n, []).append({"shards_wall_s": shard_wall, "shards_cpu_s": shard_cpu,
                                                         "merge_wall_s": merge_wall, "merge_cpu_s": merge_cpu,
                                                         "shard_lines": lines})
                        loads.append(loadavg())
            finally:
                server.stop()

        # The merge of a sharded build (N >= 2: with one shard, that shard's own pack-level entry is fetched).
        merge_s = statistics.median(r["merge_wall_s"] for n, runs in shards.items() if n >= 2 for r in runs) if shards else None

        def farm(machines, cores, with_merge=True):
            # Each shard: the whole plan and preprocessing, its share of the jobs (by a stable hash, as kiln splits
            # by key), and the merge after the slowest.
            shares = [[] for _ in range(machines)]
            for i, job in enumerate(jobs):
                h = int(hashlib.sha256(str(i).encode()).hexdigest(), 16)
                shares[h % machines].append(job)
            slowest = max(makespan(share, cores, overhead_ms) for share in shares if share)
            return serial + preprocess1 / cores + slowest + ((merge_s or 0.0) if with_merge else 0.0)

        farm_table = [{"machines": m, "cores_each": c, "model_s": farm(m, c)}
                      for c in (2, 8) for m in (1, 2, 4, 8, 16, 64)] if shards else []

        result = {
            "pack": os.path.relpath(args.pack, ROOT),
            "load_averages": loads,
            "floor": {"jobs": len(jobs), "front_end_s": floor_front, "back_end_s": floor_back,
                      "back_ends": sum(1 for _, b in jobs if b > 0)},
            "builds": {str(k): v for k, v in builds.items()},
            "calibration": {"overhead_ms_per_job": overhead_ms, "serial_s": serial, "preprocess_1_s": preprocess1,
                            "longest_job_s": longest_job_s},
            "check_j2": {"model_s": model(2), "measured_total_s": median(2, "total_s"), "measured_wall_s": median(2, "wall_s"),
                         "measured_compile_s": median(2, "compile_s"), "model_compile_s": makespan(jobs, 2, overhead_ms)},
            "check_j1": {"model_s": model(1), "measured_total_s": total1},
            "cores": cores_table,
            "shards": {str(k): v for k, v in shards.items()},
            "merge_s": merge_s,
            # Two shards side by side here, one worker each, are two one-core machines (the merge aside).
            "check_shards_2": {"model_s": farm(2, 1, with_merge=False),
                               "measured_wall_s": statistics.median(r["shards_wall_s"] for r in shards[2])} if shards else None,
            "farm": farm_table,
        }
        os.makedirs(os.path.dirname(args.out), exist_ok=True)
        with open(args.out, "w") as f:
            json.dump(result, f, indent=2)
        print(json.dumps({k: result[k] for k in ("calibration", "check_j1", "check_j2", "check_shards_2", "cores", "merge_s", "farm")},
                         indent=2))
    finally:
        shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    main()
