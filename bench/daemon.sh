# Sourced by the shell benches that run a private blobcastd on a Unix
# socket (bench_big_snapshot.sh, bench_cli_big.sh, bench_restore.sh).
#
# bench_daemon_start NAME DAEMON SOCK DATA LOG [OPTION...] starts DAEMON
# listening on the Unix socket SOCK only, with its data in DATA, its
# stderr in LOG and the OPTIONs after those; sets $pid; returns once it
# listens (its socket is there and it has said its backend), or exits
# the script with the log, naming bench NAME, when it dies or does not
# listen within 120 s (a restore of a big session from JSON took 11).
# shellcheck shell=sh
bench_daemon_start() {
	bds_name=$1
	bds_daemon=$2
	bds_sock=$3
	bds_data=$4
	bds_log=$5
	shift 5
	rm -f "$bds_sock"
	"$bds_daemon" --listen none --unix "$bds_sock" --data "$bds_data" \
		"$@" 2>"$bds_log" &
	pid=$!
	bds_i=0
	until [ -S "$bds_sock" ] && grep -q 'blobcastd: backend' "$bds_log"; do
		bds_i=$((bds_i + 1))
		if [ $bds_i -gt 2400 ] || ! kill -0 "$pid" 2>/dev/null; then
			echo "$bds_name: blobcastd ($bds_daemon) did not start:" >&2
			cat "$bds_log" >&2
			exit 1
		fi
		sleep 0.05
	done
}
