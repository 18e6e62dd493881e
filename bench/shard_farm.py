#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""Sharding over machines (issue 44): N shards and the merge against one machine, through nginx on loopback.

Each configuration runs the pack's cold build (--no-cache) as one machine (no remote) and as N shards
(`kiln build --shard I/N --remote URL`) against an empty nginx WebDAV server on 127.0.0.1, then the merge. Every
configuration once per round, rounds interleaved, medians.

Two ways to run the shards:
  --mode sequential (the default; any machine): one shard after the other, each pinned to the same `--cores` cores,
      as if each were a machine of its own with nothing else on it; the farm's time is then
          pack written = the slowest shard (until its bundle is up) + the assembly
      where the assembly is what the last shard to finish does once it finds every other shard's bundle (measured:
      the "assemble" stage of the shard that ran last). Every shard but the last finds some others missing and
      only uploads; the server holds what a parallel farm's would. After that, each shard uploads its per-source
      entries (for other checkouts' builds): "every job done" adds them (the slowest of the shards' own, or the
      assembler's after the assembly).
  --mode parallel (a machine with N x cores cores): the N shards at once, pinned to disjoint cores, from the first
      shard's start: pack written = when the shard that assembles has written the pack (when two finish together
      and neither assembles, the slowest shard's bundle + the merge job); every job done = the last shard's exit
      (+ the merge job when none assembled).

In both modes the merge job is also timed on its own: the pack-level entry is removed from the server, and a build
without --shard (a fresh process on --cores cores, no local cache) assembles the pack from the N bundles. Every pack
(the assembled one and the merge's) is compared byte for byte with the one machine's.

usage: python3 bench/shard_farm.py --kiln build/ci/compiler/kiln [--pack variants/lit.pack.json] [--shards 2,4,8,16]
                                   [--cores 2] [--reps 3] [--mode sequential|parallel] [--out FILE]
"""
import argparse
import glob
import json
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import threading
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from loopback import start_nginx  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def cpus(first, count):
    return ",".join(str(c) for c in range(first, first + count))


def build_cmd(args, out, cores_from, extra):
    return (["taskset", "-c", cpus(cores_from, args.cores), args.kiln, "build", args.pack, "-o", out, "--no-cache",
             "-j", str(args.cores), "-q", "--summary-json", os.path.join(out, "summary.json")] + extra)


def run_timed(cmd):
    start = time.perf_counter()
    done = subprocess.run(cmd, cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    wall = time.perf_counter() - start
    if done.returncode != 0:
        sys.exit(f"failed ({done.returncode}): {' '.join(cmd)}\n{done.stderr[-3000:]}")
    return wall


def summary(out):
    with open(os.path.join(out, "summary.json")) as f:
        return json.load(f)


def stage_ms(s, name):
    return sum(t["milliseconds"] for t in s["timings"] if t["stage"] == name)


def pack_bytes(out, name):
    manifest = os.path.join(out, name + ".manifest.json")
    if not os.path.exists(manifest):
        return None
    archives = sorted(glob.glob(os.path.join(out, name + ".*.kpack")))
    return open(manifest, "rb").read(), b"".join(open(a, "rb").read() for a in archives)


def forget_pack_entry(data):
    """Removes the pack-level records (kind 3) from the server's files, so the next build assembles from bundles."""
    for path in glob.glob(os.path.join(data, "**", "ac", "*"), recursive=True):
        with open(path, "rb") as f:
            head = f.read(16)
        if len(head) == 16 and head[:8] == b"KILNRMTC" and head[12] == 3:
            os.remove(path)


def load():
    return os.getloadavg()[0]


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--kiln", required=True)
    ap.add_argument("--pack", default="variants/lit.pack.json")
    ap.add_argument("--shards", default="2,4,8,16")
    ap.add_argument("--cores", type=int, default=2)
    ap.add_argument("--reps", type=int, default=3)
    ap.add_argument("--mode", choices=["sequential", "parallel"], default="sequential")
    ap.add_argument("--out")
    args = ap.parse_args()
    args.kiln = os.path.abspath(args.kiln)
    name = json.load(open(os.path.join(ROOT, args.pack)))["name"]
    counts = [int(n) for n in args.shards.split(",")]
    if args.mode == "parallel" and max(counts) * args.cores > os.cpu_count():
        sys.exit(f"--mode parallel needs {max(counts) * args.cores} cores; this machine has {os.cpu_count()}")
    work = tempfile.mkdtemp(prefix="kiln-shard-farm-")
    server, port, data = start_nginx(work)
    url = f"http://127.0.0.1:{port}/cache"
    rows = {"one": []}
    for n in counts:
        rows[n] = []
    reference = None
    try:
        for rep in range(args.reps):
            for config in ["one"] + counts:
                out_root = os.path.join(work, f"r{rep}-{config}")
                os.makedirs(out_root)
                if config == "one":
                    out = os.path.join(out_root, "one")
                    wall = run_timed(build_cmd(args, out, 0, []))
                    packed = pack_bytes(out, name)
                    if reference is None:
                        reference = packed
                    assert packed == reference, "one machine's pack differs between rounds"
                    rows["one"].append({"wall_s": wall, "load": load()})
                    print(f"round {rep} one machine: {wall:.2f} s", flush=True)
                    continue
                n = config
                shutil.rmtree(data)
                os.makedirs(data)
                shards = []
                remote = ["--remote", url, "--remote-required"]
                if args.mode == "sequential":
                    for i in range(n):
                        out = os.path.join(out_root, f"shard{i}")
                        wall = run_timed(build_cmd(args, out, 0, remote + ["--shard", f"{i}/{n}"]))
                        shards.append((out, wall, 0.0))
                    farm_start, farm_end = None, None
                else:
                    # Each shard's exit is timed by its own thread, so a shard that ends before one started earlier
                    # is not charged the other's time.
                    procs, ends = [], {}
                    farm_start = time.perf_counter()
                    for i in range(n):
                        out = os.path.join(out_root, f"shard{i}")
                        cmd = build_cmd(args, out, i * args.cores, remote + ["--shard", f"{i}/{n}"])
                        err = tempfile.TemporaryFile()
                        procs.append((out, subprocess.Popen(cmd, cwd=ROOT, stdout=subprocess.DEVNULL, stderr=err),
                                      time.perf_counter(), err))

                    def wait(i, p):
                        p.wait()
                        ends[i] = time.perf_counter()
                    waiters = [threading.Thread(target=wait, args=(i, p)) for i, (_, p, _, _) in enumerate(procs)]
                    for t in waiters:
                        t.start()
                    for t in waiters:
                        t.join()
                    for i, (out, p, started, err) in enumerate(procs):
                        if p.returncode != 0:
                            err.seek(0)
                            sys.exit(f"shard failed: {err.read().decode()[-3000:]}")
                        shards.append((out, ends[i] - started, started - farm_start))
                    farm_end = max(ends.values())
                records = []
                assembled_by = [out for out, _, _ in shards if summary(out)["shard"]["assembled"]]
                for out, wall, offset in shards:
                    s = summary(out)
                    assemble = stage_ms(s, "assemble") / 1000
                    upload = stage_ms(s, "remote upload") / 1000
                    records.append({"wall_s": wall, "assemble_s": assemble, "upload_s": upload,
                                    "ready_s": wall - assemble - upload, "offset_s": offset, "compiled": s["compiled"],
                                    "preprocess_s": stage_ms(s, "preprocess") / 1000,
                                    "plan_s": sum(stage_ms(s, st) for st in ("load", "declarations", "expand+strip")) / 1000,
                                    "back_ends": s["back_ends"], "front_ends": s["compiled"],
                                    "bundle_s": stage_ms(s, "shard bundle") / 1000,
                                    "bytes_up": s["remote"]["bytes_up"], "assembled": s["shard"]["assembled"]})
                for out in assembled_by:
                    assert pack_bytes(out, name) == reference, "an assembled pack differs from one machine's"
                # The merge job alone: from the bundles, the pack-level entry removed.
                forget_pack_entry(data)
                merge_out = os.path.join(out_root, "merge")
                merge_wall = run_timed(build_cmd(args, merge_out, 0, remote))
                m = summary(merge_out)
                assert pack_bytes(merge_out, name) == reference, "the merge's pack differs from one machine's"
                assert m["compiled"] == 0 and m["remote"]["shard_bundles"] == n, m["remote"]
                ready = [r["ready_s"] for r in records]
                assembly = sum(r["assemble_s"] for r in records)
                slowest = max(range(n), key=lambda i: ready[i])
                if args.mode == "sequential":
                    # The pack is written when the slowest shard's bundle is up and it has assembled; every job is
                    # done when, besides, each shard has uploaded its per-source entries.
                    total = ready[slowest] + assembly
                    done = max(max(r["ready_s"] + r["upload_s"] for r in records), total + records[slowest]["upload_s"])
                else:
                    # From the first shard's start: the pack is written when the assembling shard has assembled
                    # (its start, its share and bundle, then the assembly); every job is done at the last exit.
                    # When two shards finish together and neither finds the other's bundle, the merge job follows.
                    done = farm_end - farm_start + (0 if assembled_by else merge_wall)
                    writers = [r for r in records if r["assembled"]]
                    total = (min(r["offset_s"] + r["ready_s"] + r["assemble_s"] for r in writers) if writers
                             else max(r["offset_s"] + r["ready_s"] for r in records) + merge_wall)
                # What the shards did beyond their share: back ends run by two shards for one module (a module two
                # shares' sources make), and planning, which every shard does.
                row = {"shards": records, "assembled": len(assembled_by), "slowest_shard_s": ready[slowest],
                       "front_ends": sum(r["front_ends"] for r in records), "back_ends": sum(r["back_ends"] for r in records),
                       "assembly_s": assembly, "merge_job_s": merge_wall, "merge_requests_bundles": m["remote"]["shard_bundles"],
                       "merge_bytes_down": m["remote"]["bytes_down"], "total_s": total, "done_s": done, "load": load()}
                rows[n].append(row)
                print(f"round {rep} {n} shards: front ends {row['front_ends']}, back ends {row['back_ends']}; "
                      f"slowest {ready[slowest]:.2f} s (fastest {min(ready):.2f} s), assembly "
                      f"{assembly:.2f} s, pack written {total:.2f} s, every job done {done:.2f} s; merge job alone "
                      f"{merge_wall:.2f} s", flush=True)
                shutil.rmtree(out_root)
    finally:
        server.terminate()
        server.wait()
        shutil.rmtree(work, ignore_errors=True)

    one = statistics.median(r["wall_s"] for r in rows["one"])
    result = {"date": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()), "mode": args.mode, "cores_per_machine": args.cores,
              "pack": args.pack, "reps": args.reps, "machine_cpus": os.cpu_count(), "one_machine_s": one, "rows": {}}
    print(f"\none machine ({args.cores} cores, no remote): {one:.2f} s")
    print("| machines | slowest shard | assembly | pack written | speed-up | every job done | speed-up | merge job alone |")
    for n in counts:
        med = lambda key: statistics.median(r[key] for r in rows[n])  # noqa: E731
        result["rows"][str(n)] = {"slowest_shard_s": med("slowest_shard_s"), "assembly_s": med("assembly_s"),
                                  "total_s": med("total_s"), "speedup": one / med("total_s"), "done_s": med("done_s"),
                                  "done_speedup": one / med("done_s"), "merge_job_s": med("merge_job_s"), "runs": rows[n]}
        print(f"| {n} x {args.cores} | {med('slowest_shard_s'):.2f} s | {med('assembly_s'):.2f} s | {med('total_s'):.2f} s | "
              f"{one / med('total_s'):.2f}x | {med('done_s'):.2f} s | {one / med('done_s'):.2f}x | {med('merge_job_s'):.2f} s |")
    result["one_machine_runs"] = rows["one"]
    if args.out:
        with open(args.out, "w") as f:
            json.dump(result, f, indent=1)


if __name__ == "__main__":
    main()
