#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""What each remote cache fault costs a build, from its onset (issue 39 item 2: "each fault ends within 5 s").

Every fault of docs/remote-cache.md's failure table, on loopback: Debian's nginx for the answers it can be configured
to give (500, 429, 507 and 403 on uploads, damaged entries), and socket threads of this script for the rest (refused,
a connection that never completes, a server that never answers, one that drips a byte every 250 ms, a body cut
short). Each build compiles a small pack (36 stage sources) from an empty local cache, so a fault meets the build's
first request (the pack-level lookup, right after planning) and then every lookup or upload of the build. The cost
of a fault is the build's wall time minus that of the same build with no remote: the time from the fault's onset
until kiln stops waiting on the server. Rounds interleaved, medians. Writes bench/results/remote_faults.json.

usage: python3 bench/remote_faults.py --kiln build/ci/compiler/kiln [--rounds 3]
"""
import argparse
import json
import os
import shutil
import socket
import statistics
import subprocess
import sys
import tempfile
import threading
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from loopback import free_port, start_nginx, wait_listening  # noqa: E402

SHADER = """#pragma multi_compile _ A
#pragma multi_compile _ B
#pragma multi_compile_fragment _ C
#pragma multi_compile_fragment _ D
#pragma multi_compile_fragment _ E
float4 V(float4 p : POSITION) : SV_Position {
  float4 q = p;
#ifdef A
  q.x += 0.25;
#endif
#ifdef B
  q.y *= 0.5;
#endif
  return q;
}
float4 F(float4 p : SV_Position) : SV_Target {
  float c = 1.0;
#ifdef A
  c *= 0.9;
#endif
#ifdef B
  c += 0.1;
#endif
#ifdef C
  c *= sin(p.x);
#endif
#ifdef D
  c *= exp2(-p.y);
#endif
#ifdef E
  c = saturate(c * c);
#endif
  return float4(c, c, c, 1.0);
}
"""


class FaultServer:
    """silent: accepts, never answers. drip: promises 1000 bytes, sends one every 250 ms. cut: promises 1000, sends 10.
    backlogged: a full accept queue (connections never complete)."""

    def __init__(self, mode):
        self.mode, self.stopping, self.held = mode, False, []
        self.listener = socket.socket()
        self.listener.bind(("127.0.0.1", 0))
        self.port = self.listener.getsockname()[1]
        if mode == "backlogged":
            self.listener.listen(0)
            for _ in range(16):  # fill the queue until a connection does not complete
                s = socket.socket()
                s.setblocking(False)
                s.connect_ex(("127.0.0.1", self.port))
                time.sleep(0.2)
                if s.getsockopt(socket.SOL_SOCKET, socket.SO_ERROR) != 0 or not self._connected(s):
                    s.close()
                    break
                self.held.append(s)
            return
        self.listener.listen(64)
        self.listener.settimeout(0.05)
        self.thread = threading.Thread(target=self.serve, daemon=True)
        self.thread.start()

    @staticmethod
    def _connected(s):
        try:
            s.getpeername()
            return True
        except OSError:
            return False

    def serve(self):
        while not self.stopping:
            try:
                conn, _ = self.listener.accept()
            except (socket.timeout, OSError):
                continue
            if self.mode == "silent":
                self.held.append(conn)
                continue
            threading.Thread(target=self.answer, args=(conn,), daemon=True).start()

    def answer(self, conn):
        try:
            conn.settimeout(2)
            request = b""
            while b"\r\n\r\n" not in request:
                chunk = conn.recv(4096)
                if not chunk:
                    return
                request += chunk
            conn.sendall(b"HTTP/1.1 200 OK\r\nContent-Length: 1000\r\nConnection: close\r\n\r\n")
            if self.mode == "cut":
                conn.sendall(b"0123456789")
            else:
                for _ in range(1000):
                    if self.stopping:
                        break
                    time.sleep(0.25)
                    conn.sendall(b"k")
        except OSError:
            pass
        finally:
            conn.close()

    def stop(self):
        self.stopping = True
        for s in self.held:
            s.close()
        self.listener.close()


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--kiln", required=True)
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--out", default=os.path.join(ROOT, "bench/results/remote_faults.json"))
    args = parser.parse_args()
    kiln = os.path.abspath(args.kiln)
    work = tempfile.mkdtemp(prefix="kiln-faults-")
    processes, faults = [], []
    try:
        with open(os.path.join(work, "S.hlsl"), "w") as f:
            f.write(SHADER)
        with open(os.path.join(work, "p.pack.json"), "w") as f:
            json.dump({"name": "p", "passes": [{"name": "P", "source": "S.hlsl",
                                                "stages": {"vertex": "V", "fragment": "F"}}]}, f)
        servers = {}
        # nginx: a healthy one (filled, then every stored file damaged), and one per status it is told to answer.
        for name, location in (("damaged", ""), ("500", "return 500;"), ("429", "return 429;"),
                               ("507 on upload", "if ($request_method = PUT) { return 507; }"),
                               ("403 on upload", "limit_except GET HEAD { deny all; }")):
            proc, port, data = start_nginx(work, "nginx-" + name.split()[0], location)
            processes.append(proc)
            servers[name] = f"http://127.0.0.1:{port}"
            if name == "damaged":
                fill = subprocess.run([kiln, "build", "p.pack.json", "-o", "fill-out", "--cache", "fill-cache", "--remote",
                                       servers[name], "--remote-upload", "-q"], cwd=work, capture_output=True, text=True)
                if fill.returncode != 0:
                    sys.exit(fill.stderr)
                for directory, _, files in os.walk(data):
                    for file in files:
                        path = os.path.join(directory, file)
                        with open(path, "r+b") as f:
                            f.seek(os.path.getsize(path) // 2)
                            byte = f.read(1)
                            f.seek(-1, 1)
                            f.write(bytes([byte[0] ^ 0x20]))
        servers["down (refused)"] = f"http://127.0.0.1:{free_port()}"
        for mode, name in (("backlogged", "connect never completes"), ("silent", "never answers"),
                           ("drip", "drips a byte every 250 ms"), ("cut", "body cut short")):
            fault = FaultServer(mode)
            faults.append(fault)
            servers[name] = f"http://127.0.0.1:{fault.port}"
        uploads = {"507 on upload", "403 on upload"}
        cases = ["no remote"] + list(servers)
        walls = {c: [] for c in cases}
        outputs = {}
        run = 0
        for r in range(args.rounds):
            for case in cases:
                run += 1
                command = [kiln, "build", "p.pack.json", "-o", f"out-{run}", "--cache", f"cache-{run}", "-j", "2"]
                if case != "no remote":
                    command += ["--remote", servers[case]] + (["--remote-upload"] if case in uploads else [])
                start = time.perf_counter()
                out = subprocess.run(command, cwd=work, capture_output=True, text=True)
                wall = time.perf_counter() - start
                if out.returncode != 0:
                    sys.exit(f"{case}: kiln failed:\n{out.stdout}\n{out.stderr}")
                walls[case].append(wall)
                outputs[case] = out.stderr.strip().splitlines()[0] if out.stderr.strip() else ""
                shutil.rmtree(os.path.join(work, f"cache-{run}"))
                shutil.rmtree(os.path.join(work, f"out-{run}"))
                print(f"round {r + 1} {case}: {wall:.2f} s", flush=True)
        base = statistics.median(walls["no remote"])
        rows = [{"fault": c, "median_s": statistics.median(walls[c]), "walls": walls[c],
                 "cost_s": statistics.median(walls[c]) - base, "warning": outputs[c]} for c in cases]
        result = {"date": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()), "rounds": args.rounds,
                  "load_average": open("/proc/loadavg").read().split()[:3], "rows": rows}
        os.makedirs(os.path.dirname(args.out), exist_ok=True)
        with open(args.out, "w") as f:
            json.dump(result, f, indent=2)
        print("\n| fault | build (median s) | cost over no remote (s) | warning |\n|---|---|---|---|")
        for row in rows:
            print(f"| {row['fault']} | {row['median_s']:.2f} | {row['cost_s']:+.2f} | {row['warning'][:90]} |")
    finally:
        for fault in faults:
            fault.stop()
        for p in processes:
            p.terminate()
            p.wait()
        shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    main()
