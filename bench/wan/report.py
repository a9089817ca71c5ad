#!/usr/bin/env python3
"""The WAN bench's table and plot (bench/wan/run.sh) from its results file:
one line per run, "MBIT/RTT_MS ENCODING PACE JSON".

usage: report.py RESULTS SIZE [PLOT.png]
"""
import json, sys
rows = []
for line in open(sys.argv[1]):
    prof, enc, pace, js = line.split(" ", 3)
    rows.append((prof, enc, pace, json.loads(js)))
print()
print("| link | encoding | pacing | frames/s | bytes/frame | latency p50 ms | p99 ms | still ms | PSNR moving dB | PSNR still dB | decode ms | render ms | encode ms |")
print("|------|----------|--------|---------:|------------:|---------------:|-------:|---------:|---------------:|--------------:|----------:|----------:|----------:|")
for prof, enc, pace, r in rows:
    mbit, rtt = prof.split("/")
    print(f"| {mbit} Mbit/s, {rtt} ms | {enc} | {pace} | {r['delivered_fps']:.1f} | "
          f"{r['bytes_per_frame']:.0f} | {r['latency_p50_ms']:.0f} | "
          f"{r['latency_p99_ms']:.0f} | {r['still_ms']:.0f} | "
          f"{r['psnr_moving_db']:.1f} | {r['psnr_still_db']:.1f} | "
          f"{r['decode_ms']:.1f} | {r['render_ms']:.1f} | {r['encode_ms']:.1f} |")
if sys.argv[3]:
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        print("\n(no plot: apt-get install python3-matplotlib)")
        sys.exit(0)
    profs = list(dict.fromkeys(p for p, _, _, _ in rows))
    fig, (a, b) = plt.subplots(1, 2, figsize=(11, 4))
    for key in dict.fromkeys((e, p) for _, e, p, _ in rows):
        rs = {p: r for p, e, pc, r in rows if (e, pc) == key}
        xs = [i for i, p in enumerate(profs) if p in rs]
        lab = f"{key[0]}, pacing {key[1]}"
        a.plot(xs, [rs[profs[i]]['latency_p50_ms'] for i in xs], "o-", label=lab + " p50")
        a.plot(xs, [rs[profs[i]]['latency_p99_ms'] for i in xs], "x--", label=lab + " p99")
        b.plot(xs, [rs[profs[i]]['delivered_fps'] for i in xs], "o-", label=lab)
    for ax, t in ((a, "camera to decoded frame, ms"), (b, "frames/s delivered")):
        ax.set_xticks(range(len(profs)))
        ax.set_xticklabels([p.replace("/", " Mbit/s\n") + " ms" for p in profs])
        ax.set_title(f"{t} ({sys.argv[2]})")
        ax.grid(True, alpha=0.3)
    a.set_yscale("log")
    a.legend(fontsize=7)
    b.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(sys.argv[3], dpi=90)
    print(f"\nplot: {sys.argv[3]}")
