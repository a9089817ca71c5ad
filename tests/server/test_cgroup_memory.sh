#!/bin/sh
# blobcastd's default --scene-memory is half of what it may use: under a
# memory cgroup's limit (systemd's MemoryMax, a container's), half of that
# limit, also when the limit is set on a cgroup above the daemon's. Makes
# a cgroup with a 256 MiB limit and a child without one, starts the
# daemon in the child, and reads the budget from its log (128 MiB).
#
# usage: test_cgroup_memory.sh BLOBCASTD
# Exits 77 (skipped) where no memory cgroup can be made (not root, or no
# cgroup v1 memory hierarchy and no v2 memory controller to delegate).
set -u
daemon=${1:-}
if [ -z "$daemon" ] || [ ! -x "$daemon" ]; then
  echo "skip: blobcastd is not built"
  exit 77
fi
tmp=$(mktemp -d /tmp/bc-cgroup.XXXXXX) || exit 1
name=bc-test-$$
pid=
if [ -w /sys/fs/cgroup/memory ]; then
  top=/sys/fs/cgroup/memory/$name limit=memory.limit_in_bytes # v1
elif [ -f /sys/fs/cgroup/cgroup.subtree_control ] &&
  grep -qw memory /sys/fs/cgroup/cgroup.subtree_control &&
  [ -w /sys/fs/cgroup/cgroup.subtree_control ]; then
  top=/sys/fs/cgroup/$name limit=memory.max # v2
else
  echo "skip: no memory cgroup can be made here"
  rm -rf "$tmp"
  exit 77
fi
cleanup() {
  [ -n "$pid" ] && kill "$pid" 2>/dev/null && wait "$pid" 2>/dev/null
  # Back to the cgroup this script started in, so that the test's
  # cgroups are empty and can go.
  [ -d "$top/child" ] && rmdir "$top/child" 2>/dev/null
  [ -d "$top" ] && rmdir "$top" 2>/dev/null
  rm -rf "$tmp"
}
trap cleanup EXIT INT TERM
if ! mkdir "$top" 2>/dev/null; then
  echo "skip: cannot make a cgroup under $(dirname "$top")"
  exit 77
fi
if [ "$limit" = memory.max ]; then
  # v2: the memory controller for the children of the test's cgroup.
  echo +memory > "$top/cgroup.subtree_control" 2>/dev/null
fi
if ! mkdir "$top/child" || ! echo 268435456 > "$top/$limit"; then
  echo "FAIL: cannot set up $top"
  exit 1
fi
# The daemon starts in the child: its own cgroup has no limit, its
# parent 256 MiB.
sh -c 'echo $$ > "$1/cgroup.procs" && exec "$2" --listen none \
  --unix "$3/sock" --data "$3/data" --log info' sh "$top/child" \
  "$daemon" "$tmp" 2>"$tmp/log" &
pid=$!
i=0
until grep -q 'scenes: at most' "$tmp/log" 2>/dev/null; do
  i=$((i + 1))
  if [ $i -gt 600 ] || ! kill -0 "$pid" 2>/dev/null; then
    echo "FAIL: the daemon did not say its scene memory:"
    cat "$tmp/log"
    exit 1
  fi
  sleep 0.05
done
line=$(grep 'scenes: at most' "$tmp/log")
echo "$line"
case $line in
*"(--scene-memory 128 MiB,"*) echo "ok   half of the parent cgroup's 256 MiB" ;;
*)
  echo "FAIL: wanted --scene-memory 128 MiB under a 256 MiB cgroup"
  exit 1
  ;;
esac
kill "$pid"
wait "$pid" 2>/dev/null
pid=
