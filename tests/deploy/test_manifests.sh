#!/usr/bin/env bash
# deploy/k8s and deploy/nginx agree: the manifests parse, the StatefulSet
# has a volume per daemon and a headless Service for its pod names, and
# the Ingress hashes on the same key as deploy/nginx/blobcast.conf
# ($arg_session), with no retry on another daemon in either.
set -euo pipefail
root=$(cd "$(dirname "$0")/../.." && pwd)
if ! /usr/bin/python3 -c 'import yaml' 2>/dev/null; then
	echo "skipped: python3-yaml is missing (deploy/install-deps.sh)" >&2
	exit 77
fi
/usr/bin/python3 - "$root" <<'PY'
import glob, re, sys, yaml
root = sys.argv[1]
fail = 0
def check(cond, what):
    global fail
    print(("ok   " if cond else "FAIL ") + what)
    fail |= not cond
docs = []
for f in sorted(glob.glob(root + "/deploy/k8s/*.yaml")):
    docs += [d for d in yaml.safe_load_all(open(f)) if d]
kinds = {}
for d in docs:
    kinds.setdefault(d["kind"], []).append(d)
sts = kinds.get("StatefulSet", [])
check(len(sts) == 1, "one StatefulSet")
s = sts[0]["spec"]
check(bool(s.get("volumeClaimTemplates")), "a volume per daemon (volumeClaimTemplates)")
headless = [v for v in kinds.get("Service", [])
            if v["spec"].get("clusterIP") == "None"]
check(any(v["metadata"]["name"] == s["serviceName"] for v in headless),
      "serviceName is a headless Service")
names = [c["name"] for c in s["template"]["spec"]["containers"]]
check("websockify" in names and "blobcastd" in names,
      "a websockify next to each daemon")
ing = kinds.get("Ingress", [])
check(len(ing) == 1, "one Ingress")
ann = ing[0]["metadata"]["annotations"]
key = ann.get("nginx.ingress.kubernetes.io/upstream-hash-by")
conf = open(root + "/deploy/nginx/blobcast.conf").read()
m = re.search(r"^\s*hash\s+(\S+)\s+consistent;", conf, re.M)
check(m is not None, "nginx: consistent hashing")
check(m is not None and key == m.group(1) == "$arg_session",
      "the Ingress and nginx hash on the same key ($arg_session)")
check(ann.get("nginx.ingress.kubernetes.io/proxy-next-upstream") == "off"
      and "proxy_next_upstream off;" in conf and "max_fails=0" in conf,
      "no second daemon for a session (k8s and nginx)")
path = ing[0]["spec"]["rules"][0]["http"]["paths"][0]["path"]
check("location = " + path + " {" in conf,
      "the same path (%s) in both" % path)
sys.exit(1 if fail else 0)
PY
