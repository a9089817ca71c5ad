#!/bin/sh
# `blobcast watch --encoding h264 --record FILE` against a private
# blobcastd: the frames are H.264 and decode, the file holds the stream
# from a KEY frame (it starts with a start code and an SPS NAL unit), its
# size is what watch reports, and ffprobe (when installed) reads it as
# H.264 of the view's size. Refused before connecting: --record without
# --encoding h264, and a container name (.mp4) this build cannot write.
#
# usage: test_cli_video.sh BLOBCAST BLOBCASTD
# Exits 77 (skipped) when either program has not been built.
set -u
BLOBCAST=${1:-}
BLOBCASTD=${2:-}
. "$(dirname "$0")/../scratch.sh"
bc_need "$BLOBCAST" "$BLOBCASTD"

watcher=
bc_scratch cli-video '[ -n "$watcher" ] && kill "$watcher" 2>/dev/null'

# --- refusals, before any connection ------------------------------------------
"$BLOBCAST" watch --session default --encoding h264 --record "$tmp/r.mp4" \
  > "$tmp/out" 2>&1
[ $? -eq 2 ] || fail "--record .mp4 was not refused with status 2"
grep -q '\.h264' "$tmp/out" || fail "--record .mp4 said: $(cat "$tmp/out")"
[ -e "$tmp/r.mp4" ] && fail "--record .mp4 created the file"
"$BLOBCAST" watch --session default --record "$tmp/r.h264" > "$tmp/out" 2>&1
[ $? -eq 2 ] || fail "--record without --encoding h264 was not refused"
grep -q 'encoding h264' "$tmp/out" ||
  fail "--record without h264 said: $(cat "$tmp/out")"

# --- a recording ----------------------------------------------------------------
start_daemon 127.0.0.1:0
S="--server 127.0.0.1:$port"
echo "blobcastd on 127.0.0.1:$port"
"$BLOBCAST" $S watch --session default --encoding h264 --size 161x121 \
  --frames 4 --timeout 8000 --record "$tmp/rec.h264" \
  > "$tmp/watch" 2> "$tmp/watch.err" &
watcher=$!
j=0
while [ $j -lt 100 ] && ! grep -q '^frame 1 ' "$tmp/watch"; do
  sleep 0.1
  j=$((j + 1))
done
grep -q '^frame 1 ' "$tmp/watch" || fail "watch: no first frame"
# Three edits: three more pictures of the stream. Each waits for the
# picture of the one before: edits that come while a picture is still
# to be drawn share the next one (a busy machine made two of them one).
n=0
for r in 0.15 0.17 0.19; do
  "$BLOBCAST" $S edit --session default 50 radius=$r > /dev/null ||
    fail "edit radius=$r"
  n=$((n + 1))
  j=0
  while [ $j -lt 100 ] && ! grep -q "^frame .* order=$n " "$tmp/watch"; do
    sleep 0.1
    j=$((j + 1))
  done
done
wait "$watcher"
status=$?
watcher=
sed 's/^/    /' "$tmp/watch" "$tmp/watch.err"
[ "$status" -eq 0 ] || fail "watch exited $status"
grep -q 'does not decode' "$tmp/watch.err" && fail "a frame did not decode"
[ "$(grep -c '^frame [0-9]* .* image=161x121 ' "$tmp/watch")" -eq 4 ] ||
  fail "watch did not print 4 frames of 161x121"
line=$(grep '^record ' "$tmp/watch")
frames=$(echo "$line" | sed -n 's/.* frames=\([0-9]*\) .*/\1/p')
bytes=$(echo "$line" | sed -n 's/.* bytes=\([0-9]*\)$/\1/p')
[ "$line" = "record file=$tmp/rec.h264 frames=$frames bytes=$bytes" ] ||
  fail "record line: $line"
[ "${frames:-0}" -ge 1 ] || fail "no frame recorded"
[ "$(wc -c < "$tmp/rec.h264")" -eq "${bytes:-0}" ] ||
  fail "the file has $(wc -c < "$tmp/rec.h264") bytes, watch said $bytes"
head=$(od -An -tx1 -N5 "$tmp/rec.h264" | tr -d ' \n')
case $head in
  0000000167 | 00000167*) echo "ok   starts with a start code and an SPS" ;;
  *) fail "the file starts with $head, not a start code and an SPS" ;;
esac
if command -v ffprobe > /dev/null 2>&1; then
  ffprobe -v error -select_streams v:0 -show_entries \
    stream=codec_name,width,height -of csv=p=0 "$tmp/rec.h264" \
    > "$tmp/probe" 2>&1 || fail "ffprobe: $(cat "$tmp/probe")"
  grep -q '^h264,161,121' "$tmp/probe" ||
    fail "ffprobe read: $(cat "$tmp/probe")"
else
  echo "ffprobe is not installed: the file is checked by its first bytes"
fi
stop_daemon
[ "$failures" -eq 0 ] || exit 1
echo "all checks passed"
