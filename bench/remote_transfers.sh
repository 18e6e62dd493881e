#!/usr/bin/env bash
# Parallel transfers against a filled server (bench/REPORT.md, section 5): after bench/remote_cache.sh, in its work
# directory, serves its nginx data again and fetches every stage source of checkout b (another path: no pack-level
# hit) from an empty local cache with --remote-transfers 1, 2, 4, 8, 16, interleaved.
# Usage: bench/remote_transfers.sh <kiln> <workdir of remote_cache.sh> [rounds]
set -euo pipefail
kiln=$(realpath "$1"); w=$(realpath "$2"); rounds=${3:-3}; s=$w/server
cp "$w/a/shaderlib/Fog.hlsl" "$w/b/shaderlib/Fog.hlsl"  # undo remote_cache.sh's include edit
port=$(python3 -c 'import socket; s=socket.socket(); s.bind(("127.0.0.1",0)); print(s.getsockname()[1])')
sed -i "s/listen 127.0.0.1:[0-9]*;/listen 127.0.0.1:$port;/" "$s/nginx.conf"
/usr/sbin/nginx -p "$s/" -c "$s/nginx.conf" -e "$s/error.log" & pid=$!
trap 'kill $pid; wait $pid || true' EXIT
for _ in $(seq 100); do (exec 3<>/dev/tcp/127.0.0.1/$port) 2>/dev/null && break; sleep 0.05; done
for r in $(seq "$rounds"); do
  for t in 1 2 4 8 16; do
    rm -rf "$w/b/out-t" "$w/b/cache-t"
    start=$(date +%s.%N)
    (cd "$w/b" && "$kiln" build variants/lit.pack.json -o out-t --cache cache-t --remote "http://127.0.0.1:$port" --remote-transfers $t > "$w/t.out" 2>&1)
    end=$(date +%s.%N)
    echo "transfers $t round $r: $(echo "$end - $start" | bc) s; $(grep -o 'compiled [0-9]*' "$w/t.out"); $(grep -o 'hits [0-9]*, misses [0-9]*' "$w/t.out" | head -1); compile stage: $(grep -o 'compile [0-9.]* m\?s' "$w/t.out")"
  done
done
