#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# The remote cache on loopback (bench/REPORT.md, "The remote cache on loopback"): cold build; a second client warm
# from the remote (per stage source, from a checkout whose pack definition differs by one byte; and the pack-level entry); the hit rate
# after an include edit; the cost of a remote that is down (connection refused) on a build that is warm locally.
# Runs are interleaved, medians reported; writes bench/results/remote_cache.json (bench/report.py renders it).
# Usage: bench/remote_cache.sh <kiln> <source dir> <rounds> [workdir]
set -euo pipefail
kiln=$(realpath "$1"); source_dir=$(realpath "$2"); rounds=${3:-3}
work=${4:-$(mktemp -d /tmp/kiln-remote-bench-XXXXXX)}
mkdir -p "$work"; work=$(realpath "$work")

# nginx with WebDAV PUT, in the foreground, stopped by its PID.
port=$(python3 -c 'import socket; s=socket.socket(); s.bind(("127.0.0.1",0)); print(s.getsockname()[1])')
server=$work/server; mkdir -p "$server/data" "$server/tmp"
cat > "$server/nginx.conf" <<EOF
daemon off; master_process off; worker_processes 1; pid $server/nginx.pid; error_log $server/error.log;
events { worker_connections 256; }
http { access_log $server/access.log; client_body_temp_path $server/tmp/body; proxy_temp_path $server/tmp/proxy;
  fastcgi_temp_path $server/tmp/fastcgi; uwsgi_temp_path $server/tmp/uwsgi; scgi_temp_path $server/tmp/scgi;
  client_max_body_size 512m;
  server { listen 127.0.0.1:$port; root $server/data;
    location / { dav_methods PUT; create_full_put_path on; dav_access user:rw; } } }
EOF
/usr/sbin/nginx -p "$server/" -c "$server/nginx.conf" -e "$server/error.log" &
nginx_pid=$!
trap 'kill $nginx_pid 2>/dev/null || true; wait $nginx_pid 2>/dev/null || true' EXIT
for _ in $(seq 100); do (exec 3<>/dev/tcp/127.0.0.1/$port) 2>/dev/null && break; sleep 0.05; done
url=http://127.0.0.1:$port
down=http://127.0.0.1:$(python3 -c 'import socket; s=socket.socket(); s.bind(("127.0.0.1",0)); print(s.getsockname()[1])')

# Two checkouts: "a" uploads; "b" is the same files at another path with one byte more in the pack definition (a
# trailing newline: the inputs hash, and so the pack-level key, differ; every stage source and its key is the same),
# so that b reads the per-source entries. (The same files at another path alone read the pack-level entry.)
for c in a b; do mkdir -p "$work/$c"; cp -r "$source_dir/variants" "$source_dir/shaderlib" "$work/$c/"; done
echo >> "$work/b/variants/lit.pack.json"
pack=variants/lit.pack.json
seconds() { local start end; start=$(date +%s.%N); "$@" > "$work/last.out" 2> "$work/last.err"; end=$(date +%s.%N); echo "$end - $start" | bc; }
requests() { wc -l < "$server/access.log"; }

echo "populating the server from checkout a (cold, --remote-upload)"
(cd "$work/a" && seconds "$kiln" build $pack -o out-upload --cache cache-upload --remote "$url" --remote-upload) | tee "$work/upload.time"
cp "$work/last.out" "$work/upload.out"; cat "$work/upload.out"
declare -A times
for r in $(seq "$rounds"); do
  # cold: no remote, empty local cache
  times[cold]+=" $(cd "$work/a" && seconds "$kiln" build $pack -o out-cold-$r --cache cache-cold-$r)"
  # warm from the remote, per stage source: checkout b, empty local cache
  before=$(requests)
  times[remote_sources]+=" $(cd "$work/b" && seconds "$kiln" build $pack -o out-remote-$r --cache cache-remote-$r --remote "$url")"
  source_requests=$(( $(requests) - before )); source_line=$(grep 'remote cache' "$work/last.out")
  echo "per-source fetch: $source_requests requests; $source_line"
  grep -q "compiled 0 " "$work/last.out" || { echo "expected 0 compiles"; cat "$work/last.out" "$work/last.err"; exit 1; }
  # warm from the remote, the pack-level entry: checkout a, empty local cache, new output directory
  before=$(requests)
  times[remote_pack]+=" $(cd "$work/a" && seconds "$kiln" build $pack -o out-pack-$r --cache cache-pack-$r --remote "$url")"
  pack_requests=$(( $(requests) - before )); pack_line=$(grep 'remote cache' "$work/last.out")
  echo "pack-level fetch: $pack_requests requests; $pack_line"
  # warm locally (new output directory), without a remote and with a remote that refuses connections
  times[local_warm]+=" $(cd "$work/a" && seconds "$kiln" build $pack -o out-local-$r --cache cache-upload)"
  times[local_warm_remote_down]+=" $(cd "$work/a" && seconds "$kiln" build $pack -o out-down-$r --cache cache-upload --remote "$down")"
  grep -q "K1701" "$work/last.err" || { echo "expected K1701"; cat "$work/last.err"; exit 1; }
done
for r in $(seq "$rounds"); do
  cmp "$work/a/out-cold-$r/lit.manifest.json" "$work/a/out-pack-$r/lit.manifest.json"
  cmp "$work/a/out-cold-$r/$(cd "$work/a/out-cold-$r" && ls *.kpack)" "$work/b/out-remote-$r/$(cd "$work/b/out-remote-$r" && ls *.kpack)"
done
echo "packs: byte-identical (cold vs pack-level fetch: manifest and archive; cold vs per-source fetch: archive)"

# An include edit: a constant in a file some variants include; checkout b (another path) reads the remote.
sed -i '0,/1.44269504/s//1.4427/' "$work/b/shaderlib/Fog.hlsl"  # the fog falloff's constant: exponential fog only
(cd "$work/b" && "$kiln" build $pack -o out-edit --cache cache-edit --remote "$url") > "$work/edit.out" 2>&1 || true
edit_line=$(grep -E 'compiled|remote cache' "$work/edit.out" | tr -s ' ' | tr '\n' ';')
echo "after an include edit: $edit_line"

median() { printf '%s\n' $1 | sort -g | awk '{a[NR]=$1} END {print (NR%2 ? a[(NR+1)/2] : (a[NR/2]+a[NR/2+1])/2)}'; }
echo "medians of $rounds interleaved runs (s):"
for k in cold remote_sources remote_pack local_warm local_warm_remote_down; do
  printf '  %-24s %8.3f   (%s)\n' "$k" "$(median "${times[$k]}")" "${times[$k]# }"
done
objects=$(find "$server/data" -type f | wc -l); bytes=$(du -sb "$server/data" | cut -f1)
echo "server: $objects objects, $bytes bytes"
upload_line=$(grep 'remote cache' "$work/upload.out" || true)
python3 - "$source_dir/bench/results/remote_cache.json" <<PY
import json, sys, datetime, statistics
times = {k: [float(x) for x in v.split()] for k, v in {
    "cold": "${times[cold]}", "remote_sources": "${times[remote_sources]}", "remote_pack": "${times[remote_pack]}",
    "local_warm": "${times[local_warm]}", "local_warm_remote_down": "${times[local_warm_remote_down]}"}.items()}
json.dump({"date": datetime.datetime.utcnow().strftime("%Y-%m-%d %H:%M UTC"), "rounds": $rounds,
           "seconds": times, "medians": {k: statistics.median(v) for k, v in times.items()},
           "upload": """$upload_line""".strip(), "per_source": {"requests": $source_requests, "summary": """$source_line""".strip()},
           "pack_level": {"requests": $pack_requests, "summary": """$pack_line""".strip()},
           "include_edit": """$edit_line""".strip(), "server": {"objects": $objects, "bytes": $bytes}},
          open(sys.argv[1], "w"), indent=2)
PY
echo "wrote $source_dir/bench/results/remote_cache.json"
