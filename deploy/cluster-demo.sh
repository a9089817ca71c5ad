#!/usr/bin/env bash
# Several blobcastd daemons behind one front door, on this machine: N
# daemons (default 3), a websockify next to each, and nginx terminating TLS
# on one port and routing every client -- the page, the CLI, the viewer --
# to the daemon that holds its session (consistent hashing on the session
# name, deploy/nginx/blobcast.conf). Prints the addresses and runs until
# Ctrl-C or SIGTERM (or until nginx dies).
#
#   deploy/cluster-demo.sh [--port P] [--data DIR] [--daemons N]
#
# nginx listens on 127.0.0.1:P (default 8443, TLS with a certificate made
# here by a CA made here: DIR/tls/ca.pem); daemon i on 127.0.0.1:P+10+i
# with its data in DIR/node-i; its websockify on 127.0.0.1:P+20+i. Reach a
# session through the front door with
#   blobcast nodes --server 'wss://127.0.0.1:P/blobcast?session=NAME' \
#       --ca DIR/tls/ca.pem --session NAME
# or open https://127.0.0.1:P/?session=NAME&ws=wss://127.0.0.1:P/blobcast%3Fsession%3DNAME
# Without --data everything lives in a temporary directory removed at
# exit. DIR/cluster.env records the ports and process ids. blobcastd is
# $BLOBCASTD or the first build*/server/blobcastd; nginx, websockify and
# openssl come from Debian (deploy/install-deps.sh).
set -euo pipefail

root=$(cd "$(dirname "$0")/.." && pwd)
port=8443
data=
n=3
while [ $# -gt 0 ]; do
	case "$1" in
	--port) port=${2:?--port needs a number}; shift 2 ;;
	--data) data=${2:?--data needs a directory}; shift 2 ;;
	--daemons) n=${2:?--daemons needs a number}; shift 2 ;;
	-h|--help) sed -n '2,21p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
	*) echo "cluster-demo: unknown argument $1 (try --help)" >&2; exit 2 ;;
	esac
done
case "$port$n" in
*[!0-9]*) echo "cluster-demo: --port and --daemons want numbers" >&2; exit 2 ;;
esac
if [ "$port" -lt 1024 ] || [ "$port" -gt 65500 ] || [ "$n" -lt 1 ] ||
	[ "$n" -gt 9 ]; then
	echo "cluster-demo: --port 1024..65500, --daemons 1..9" >&2
	exit 2
fi

daemon=${BLOBCASTD:-}
if [ -z "$daemon" ]; then
	for d in "$root"/build*/server/blobcastd; do
		if [ -x "$d" ]; then daemon=$d; break; fi
	done
fi
if [ -z "$daemon" ] || [ ! -x "$daemon" ]; then
	echo "cluster-demo: blobcastd is not built (cmake --build build --target blobcastd)" >&2
	exit 1
fi
nginx=$(command -v nginx || echo /usr/sbin/nginx)
for tool in "$nginx" websockify openssl; do
	if ! command -v "$tool" >/dev/null 2>&1; then
		echo "cluster-demo: $tool is missing (deploy/install-deps.sh)" >&2
		exit 1
	fi
done

if [ -z "$data" ]; then
	data=$(mktemp -d /tmp/blobcast-cluster.XXXXXX)
	remove_data=1
else
	mkdir -p "$data"
	data=$(cd "$data" && pwd)
	remove_data=0
fi
pids=()
cleanup() {
	trap - EXIT INT TERM
	for p in "${pids[@]}"; do kill "$p" 2>/dev/null || true; done
	for p in "${pids[@]}"; do wait "$p" 2>/dev/null || true; done
	if [ -f "$data/cluster.env" ]; then
		# daemons restarted by hand since (docs/deploy.md) are ours too
		for f in "$data"/node-*.pid; do
			[ -f "$f" ] && kill "$(cat "$f")" 2>/dev/null || true
		done
	fi
	[ "$remove_data" = 1 ] && rm -rf "$data"
	return 0
}
trap cleanup EXIT
trap 'exit 0' INT TERM

# Every port must be free: something already answering on one would pass
# for ours below.
for p in "$port" $(seq $((port + 10)) $((port + 9 + n))) \
	$(seq $((port + 20)) $((port + 19 + n))); do
	if (exec 3<>"/dev/tcp/127.0.0.1/$p") 2>/dev/null; then
		echo "cluster-demo: port $p on 127.0.0.1 is in use; choose another --port" >&2
		exit 1
	fi
done

# A CA and a certificate for this machine's loopback names.
tls=$data/tls
mkdir -p "$tls"
if [ ! -f "$tls/server.key" ]; then
	openssl req -x509 -newkey ec -pkeyopt ec_paramgen_curve:P-256 -nodes \
		-keyout "$tls/ca.key" -out "$tls/ca.pem" -days 30 \
		-subj "/CN=blobcast cluster demo CA" 2>/dev/null
	openssl req -newkey ec -pkeyopt ec_paramgen_curve:P-256 -nodes \
		-keyout "$tls/server.key" -out "$tls/server.csr" \
		-subj /CN=localhost 2>/dev/null
	printf 'subjectAltName=DNS:localhost,IP:127.0.0.1\n' > "$tls/ext"
	openssl x509 -req -in "$tls/server.csr" -CA "$tls/ca.pem" \
		-CAkey "$tls/ca.key" -CAcreateserial -days 30 \
		-extfile "$tls/ext" -out "$tls/server.crt" 2>/dev/null
fi

: > "$data/cluster.env"
echo "FRONT_PORT=$port" >> "$data/cluster.env"
upstreams=
for i in $(seq 0 $((n - 1))); do
	dport=$((port + 10 + i))
	wport=$((port + 20 + i))
	mkdir -p "$data/node-$i"
	"$daemon" --listen "127.0.0.1:$dport" --data "$data/node-$i" \
		--server-id "node-$i" 2> "$data/node-$i.log" &
	pids+=($!)
	echo $! > "$data/node-$i.pid"
	websockify "127.0.0.1:$wport" "127.0.0.1:$dport" \
		> "$data/websockify-$i.log" 2>&1 &
	pids+=($!)
	echo "NODE_${i}_PORT=$dport NODE_${i}_WS_PORT=$wport" >> "$data/cluster.env"
	upstreams="$upstreams	server 127.0.0.1:$wport max_fails=0;\\n"
done

# nginx: the shipped site configuration with this demo's addresses, inside
# a minimal main configuration of its own (no root needed).
mkdir -p "$data/nginx"
sed -e '/^	server 10\.0\.0\./d' \
	-e "s|^	hash \$arg_session consistent;|&\\n$upstreams|" \
	-e "s|listen 443 ssl;|listen 127.0.0.1:$port ssl;|" \
	-e '/listen \[::\]:443 ssl;/d' \
	-e 's|server_name blobcast.example.org;|server_name localhost;|' \
	-e "s|/etc/blobcast/tls.crt|$tls/server.crt|" \
	-e "s|/etc/blobcast/tls.key|$tls/server.key|" \
	-e "s|/usr/local/share/blobcast/web|$root/client/web|" \
	"$root/deploy/nginx/blobcast.conf" > "$data/nginx/blobcast.conf"
cat > "$data/nginx/nginx.conf" <<CONF
worker_processes 1;
pid $data/nginx/nginx.pid;
error_log $data/nginx/error.log warn;
events { worker_connections 512; }
http {
	access_log $data/nginx/access.log;
	client_body_temp_path $data/nginx/tmp;
	proxy_temp_path $data/nginx/tmp;
	fastcgi_temp_path $data/nginx/tmp;
	uwsgi_temp_path $data/nginx/tmp;
	scgi_temp_path $data/nginx/tmp;
	types { text/html html; text/javascript js mjs; text/css css; }
	include $data/nginx/blobcast.conf;
}
CONF
mkdir -p "$data/nginx/tmp"
"$nginx" -t -q -p "$data/nginx" -c "$data/nginx/nginx.conf" \
	-e "$data/nginx/error.log" 2>> "$data/nginx/error.log" || {
	echo "cluster-demo: nginx refused its configuration:" >&2
	cat "$data/nginx/error.log" >&2
	exit 1
}
"$nginx" -p "$data/nginx" -c "$data/nginx/nginx.conf" \
	-e "$data/nginx/error.log" -g 'daemon off;' &
nginx_pid=$!
pids+=($nginx_pid)
echo "NGINX_PID=$nginx_pid DATA=$data" >> "$data/cluster.env"

# Ready when the front door answers and every daemon listens: up to a
# minute, for a loaded machine; at once when one of them has died.
ready=0
for _ in $(seq 1 1200); do
	for p in "${pids[@]}"; do
		if ! kill -0 "$p" 2>/dev/null; then
			echo "cluster-demo: a process exited while starting; see $data/*.log and $data/nginx/error.log:" >&2
			tail -n 5 "$data"/node-*.log "$data"/websockify-*.log "$data/nginx/error.log" >&2 2>/dev/null || true
			exit 1
		fi
	done
	ok=1
	for i in $(seq 0 $((n - 1))); do
		grep -q 'blobcastd: backend' "$data/node-$i.log" 2>/dev/null || ok=0
		(exec 3<>"/dev/tcp/127.0.0.1/$((port + 20 + i))") 2>/dev/null ||
			ok=0
	done
	if [ $ok = 1 ] && (exec 3<>"/dev/tcp/127.0.0.1/$port") 2>/dev/null; then
		ready=1
		break
	fi
	sleep 0.05
done
if [ $ready != 1 ]; then
	echo "cluster-demo: not every daemon, websockify and nginx answered within a minute; see $data/*.log and $data/nginx/error.log" >&2
	exit 1
fi
echo "cluster-demo: $n daemons behind https://127.0.0.1:$port (CA $tls/ca.pem)"
echo "  blobcast nodes --server 'wss://127.0.0.1:$port/blobcast?session=NAME' --ca $tls/ca.pem --session NAME"
echo "  page: https://127.0.0.1:$port/?session=NAME&ws=wss://127.0.0.1:$port/blobcast%3Fsession%3DNAME"
echo "cluster-demo: ready"
wait "$nginx_pid"
