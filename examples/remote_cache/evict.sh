#!/bin/sh
# SPDX-License-Identifier: Apache-2.0
# Keeps a kiln remote cache directory (the root an nginx or Apache WebDAV server serves) under a size: deletes the
# files read least recently first, until the rest fits. Run it on the server from cron or a systemd timer:
#
#   evict.sh /srv/kiln-cache 50G        # sizes as numfmt --from=iec reads them: 50G, 512M, 1048576
#
# What a build sees when an entry it needs was evicted, even between two of its requests: a plain miss, compiled
# again (never an error, also with --remote-required); an uploading build puts the entry back. Access times are the
# file system's: with `relatime` (Linux's default) a file's is updated by its first read after a write and then
# at most once a day, which is the resolution this eviction has; with `noatime` it is the time of the upload.
# Files are deleted oldest first, ties in path order; the finished pack's entries are files like any other.
set -eu
if [ $# -ne 2 ] || [ ! -d "$1" ]; then
  echo "usage: evict.sh CACHE_DIRECTORY MAX_SIZE" >&2
  exit 2
fi
directory=$1
limit=$(numfmt --from=iec "$2") || { echo "evict.sh: '$2' is not a size (50G, 512M, 1048576)" >&2; exit 2; }
# One line per file: access time, size, path (the cache's names are hex digests: no spaces or line breaks).
find "$directory" -type f -printf '%A@ %s %p\n' | LC_ALL=C sort -k1,1n -k3,3 |
  awk -v limit="$limit" '
    { time[NR] = $1; size[NR] = $2; path[NR] = $3; total += $2 }
    END { for (i = 1; i <= NR && total > limit; i++) { print path[i]; total -= size[i] } }' |
  while IFS= read -r file; do rm -f -- "$file"; done
