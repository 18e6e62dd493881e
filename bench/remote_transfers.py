#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""How many remote requests kiln should keep in flight, and whether libcurl's multi interface would pay (issue 24).

kiln fetches from the remote cache with `--remote-transfers N` threads, each with one kept-alive libcurl handle (one
connection). The multi interface would be the cheap way to keep many more requests in flight than threads; it can
only pay if more in flight is faster. This measures the per-source fetch of the default pack (checkout b: the
pack-level entry misses, every stage source is fetched: alias, record, blobs) at N = 1 ... 64, against Debian's nginx
directly (loopback) and through a delay proxy that holds each client-to-server chunk for D ms (an emulated round
trip; loopback has no netem here). Each run records the whole build's wall time and its compile stage (the remote
lookups, downloads and checks: nothing is compiled), which is what the transfers change. Rounds interleaved,
medians. Writes bench/results/remote_transfers.json. (Replaces bench/remote_transfers.sh, loopback only.)

usage: python3 bench/remote_transfers.py --kiln build/ci/compiler/kiln [--rounds 3] [--delay-ms 5]
       python3 bench/remote_transfers.py --proxy LISTEN_PORT UPSTREAM_PORT DELAY_MS   (the delay proxy itself)
"""
import argparse
import asyncio
import json
import os
import re
import shutil
import statistics
import subprocess
import sys
import tempfile
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from loopback import free_port, start_nginx, wait_listening  # noqa: E402


def run_proxy(listen, upstream, delay_ms):
    """Forwards each connection to the upstream; client-to-server chunks wait `delay_ms` first (kept in order)."""
    async def pipe(reader, writer, delay):
        try:
            while data := await reader.read(65536):
                if delay:
                    await asyncio.sleep(delay)
                writer.write(data)
                await writer.drain()
        except (ConnectionError, asyncio.CancelledError):
            pass
        finally:
            writer.close()

    async def handle(client_reader, client_writer):
        server_reader, server_writer = await asyncio.open_connection("127.0.0.1", upstream)
        await asyncio.gather(pipe(client_reader, server_writer, delay_ms / 1000.0), pipe(server_reader, client_writer, 0))

    async def main():
        server = await asyncio.start_server(handle, "127.0.0.1", listen, backlog=512)
        async with server:
            await server.serve_forever()

    asyncio.run(main())



def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--kiln")
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--delay-ms", type=float, default=5.0)
    parser.add_argument("--transfers", default="1,2,4,8,16,32,64")
    parser.add_argument("--proxy", nargs=3, type=float, metavar=("LISTEN", "UPSTREAM", "DELAY_MS"))
    parser.add_argument("--out", default=os.path.join(ROOT, "bench/results/remote_transfers.json"))
    args = parser.parse_args()
    if args.proxy:
        run_proxy(int(args.proxy[0]), int(args.proxy[1]), args.proxy[2])
        return
    kiln = os.path.abspath(args.kiln)
    counts = [int(n) for n in args.transfers.split(",")]
    work = tempfile.mkdtemp(prefix="kiln-transfers-")
    processes = []
    try:
        nginx, port, _ = start_nginx(work)
        processes.append(nginx)
        proxy_port = free_port()
        processes.append(subprocess.Popen([sys.executable, os.path.abspath(__file__), "--proxy", str(proxy_port), str(port),
                                           str(args.delay_ms)]))
        wait_listening(proxy_port)
        # Checkout a uploads; checkout b has one byte more in its pack definition: its pack-level key misses and every
        # stage source is fetched (as bench/remote_cache.sh's per-source row).
        for c in ("a", "b"):
            for d in ("variants", "shaderlib"):
                shutil.copytree(os.path.join(ROOT, d), os.path.join(work, c, d))
        with open(os.path.join(work, "b/variants/lit.pack.json"), "a") as f:
            f.write("\n")
        pack = "variants/lit.pack.json"
        upload = subprocess.run([kiln, "build", pack, "-o", "out", "--cache", "cache", "--remote", f"http://127.0.0.1:{port}",
                                 "--remote-upload"], cwd=os.path.join(work, "a"), capture_output=True, text=True)
        if upload.returncode != 0:
            sys.exit(upload.stderr)
        servers = {"loopback": port, f"+{args.delay_ms:g} ms per request": proxy_port}
        walls = {(s, n): [] for s in servers for n in counts}
        stages = {(s, n): [] for s in servers for n in counts}
        loads = []
        run = 0
        for r in range(args.rounds):
            for name, p in servers.items():
                for n in counts:
                    run += 1
                    cache = os.path.join(work, f"cache-{run}")
                    start = time.perf_counter()
                    out = subprocess.run([kiln, "build", pack, "-o", f"out-{run}", "--cache", cache, "--remote",
                                          f"http://127.0.0.1:{p}", "--remote-transfers", str(n)],
                                         cwd=os.path.join(work, "b"), capture_output=True, text=True)
                    wall = time.perf_counter() - start
                    if out.returncode != 0 or "compiled 0 " not in out.stdout or out.stderr:
                        sys.exit(f"expected a clean fetch with 0 compiles:\n{out.stdout}\n{out.stderr}")
                    shutil.rmtree(cache)
                    shutil.rmtree(os.path.join(work, "b", f"out-{run}"))
                    walls[(name, n)].append(wall)
                    m = re.search(r"compile ([0-9.]+) (m?s)", out.stdout)
                    stages[(name, n)].append(float(m.group(1)) / (1000.0 if m.group(2) == "ms" else 1.0))
                    loads.append(open("/proc/loadavg").read().split()[0])
                    print(f"round {r + 1} {name}, --remote-transfers {n}: {wall:.2f} s, compile stage "
                          f"{stages[(name, n)][-1]:.2f} s", flush=True)
        summary = next(line.strip() for line in out.stdout.splitlines() if "remote cache" in line)
        rows = [{"server": s, "transfers": n, "median_s": statistics.median(walls[(s, n)]), "walls": walls[(s, n)],
                 "median_fetch_s": statistics.median(stages[(s, n)]), "fetch_s": stages[(s, n)]}
                for s in servers for n in counts]
        result = {"date": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()), "rounds": args.rounds,
                  "delay_ms": args.delay_ms, "load_averages": loads, "last_summary": summary, "rows": rows}
        os.makedirs(os.path.dirname(args.out), exist_ok=True)
        with open(args.out, "w") as f:
            json.dump(result, f, indent=2)
        for row in rows:
            print(f"{row['server']:>24} transfers {row['transfers']:>3}: build {row['median_s']:.2f} s, "
                  f"fetch (compile stage) {row['median_fetch_s']:.2f} s")
    finally:
        for p in processes:
            p.terminate()
            p.wait()
        shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    main()
