#!/bin/bash
# RSS of blobcastd (MiB) as big scenes replace one another: 200 000
# spheres loaded with `blobcast load`, a viewer drawing 1024x768, a
# million spheres, the default scene, the session deleted.
# Usage: bench/replace_rss.sh PATH/TO/blobcastd PATH/TO/blobcast [WORKDIR]
set -eu
D=$1 C=$2 W=${3:-/tmp/bc-replace-rss}
S=$W/sock DIR=$W/data
mkdir -p "$W"
for n in 200000 1000000; do
	[ -s "$W/s$n.json" ] || "$C" gen fig18 --count $n --kind spheres \
		--blend smooth --out "$W/s$n.json"
done
"$C" gen default --out "$W/default.json"
rm -rf "$DIR" "$S" && mkdir "$DIR"
"$D" --listen none --unix "$S" --data "$DIR" --log info 2>"$W/log" &
P=$!
trap 'kill $P 2>/dev/null' EXIT
for _ in $(seq 100); do [ -S "$S" ] && break; sleep 0.1; done
rss() { awk '/VmRSS/{printf "%d", $2/1024}' /proc/$P/status; }
hwm() { awk '/VmHWM/{printf "%d", $2/1024}' /proc/$P/status; }
load() { "$C" --server "unix:$S" --timeout 0 load --session big "$1" >/dev/null; }
echo -n "start $(rss)"
load "$W/s200000.json"
timeout 300 "$C" --server "unix:$S" --timeout 0 watch --session big \
	--frames 100 --size 1024x768 >"$W/watch" 2>&1 &
V=$!
sleep 4
echo -n " 200k+view $(rss)"
load "$W/s1000000.json"; sleep 8
echo -n " 1M $(rss) hwm $(hwm)"
load "$W/default.json"; sleep 4
echo -n " default $(rss)"
kill $V
"$C" --server "unix:$S" --timeout 0 delete --session big >/dev/null 2>&1
sleep 3
echo " deleted $(rss)"
