"""Memory of a progressive render against its pass count: the peak resident set of a render of
P passes, each in a fresh process, side by side; in this process or in local worker processes
(``--workers N``: the peak of the largest worker beside the driver's own).

A render keeps one pass's photons, index, gather and GL textures at a time (its textures
reused from pass to pass, ``blockhash.gl.pool``), and a film of (h, w, 3) float64 means; its
peak should not grow with the passes.  ``--marks`` prints the peak after those passes too
(in this process only); ``--env NAME=VALUE`` runs every count again under that environment
(e.g. glibc's ``MALLOC_MMAP_THRESHOLD_``), beside the plain one.

Several ``--photons`` counts give the slope: the peak's growth between two counts over the
growth of the photons stored a pass, in bytes a stored photon (of the process, or of the
largest worker with ``--workers``); the passes in flight in one process are 2 with the next
pass traced ahead (``--overlap on``, the default) and 1 without.

usage: python tools/pass_memory.py [--scene scenes/ring.toml] [--photons 20000,1000000,3000000]
                                   [--passes 2,100] [--size 512] [--marks 1,5,10]
                                   [--method auto|cpu] [--workers 0|N]
                                   [--env MALLOC_MMAP_THRESHOLD_=131072 ...]
"""

import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

from blockhash.studies.command import ToolParser, count, listing

#: The checkout measured: this tool's own (its child runs outside any checkout, so that no
#: other ``blockhash`` on the path is imported).
ROOT = Path(__file__).resolve().parents[1]

CHILD = """
import json, resource, sys, time
import blockhash
from blockhash.frame.options import LookupOptions
from blockhash.passes.executors import InProcess, LocalWorkers
from blockhash.passes.renderer import Renderer
from blockhash.passes.run import run_passes
scene = blockhash.load_scene(sys.argv[1]).with_size(int(sys.argv[2]), int(sys.argv[2]))
marks = {int(m) for m in sys.argv[5].split(",") if m}
workers, overlap = int(sys.argv[7]), sys.argv[8] == "on"
r = Renderer(scene, photons=int(sys.argv[3]), lookup=LookupOptions(method=sys.argv[6]))
peaks, t = {}, time.perf_counter()
def on_pass(renderer, stats, elapsed, session):
    if renderer.passes in marks:
        peaks[renderer.passes] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
executor = LocalWorkers(workers) if workers else InProcess(overlap=overlap)
run_passes(r, blockhash.RenderPlan(passes=int(sys.argv[4]), executor=executor), on_pass=on_pass)
print(json.dumps({"passes": r.passes, "seconds": time.perf_counter() - t,
                  "peak_mib": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
                  "worker_peak_mib": resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024,
                  "peaks_at": peaks, "emitted": r.emitted, "stored": r.stored}))
"""


def run(args, photons: int, n: int, env: dict) -> dict:
    out = subprocess.run([sys.executable, "-c", CHILD, str(Path(args.scene).resolve()), str(args.size),
                          str(photons), str(n), ",".join(map(str, args.marks)), args.method,
                          str(args.workers), args.overlap],
                         capture_output=True, text=True, check=True, cwd=tempfile.gettempdir(),
                         env={**os.environ, "PYTHONPATH": str(ROOT), **env})
    return json.loads(out.stdout.strip().splitlines()[-1])


def main(argv=None):
    p = ToolParser(__doc__, __file__)
    p.scenes("scenes/ring.toml", many=False)
    p.photons([1_000_000], many=True, help="photons per pass (several: the slope between them)")
    p.add_argument("--passes", type=listing(count), default=[2, 100],
                   help="pass counts, each a render of its own (default 2,100)")
    p.size(512)
    p.add_argument("--method", default="auto", help="the photon search (LookupOptions): auto, "
                   "or cpu for a render with no GL caustic pass")
    p.add_argument("--workers", type=int, default=0, help="local worker processes (0: the "
                   "render in this process)")
    p.add_argument("--overlap", choices=("on", "off"), default="on", help="in this process: the "
                   "next pass's photons traced while this pass renders (on, the default) or not")
    p.add_argument("--marks", type=listing(count), default=[],
                   help="passes after which to print the peak so far")
    p.add_argument("--env", action="append", default=[], metavar="NAME=VALUE",
                   help="also run under this environment variable (repeatable)")
    args = p.parse_args(argv)
    settings = [("default", {})] + [(e, dict([e.split("=", 1)])) for e in args.env]
    where = f"{args.workers} local workers" if args.workers else "in process"
    shown = ",".join(map(str, args.marks)) or "-"
    print(f"| environment | passes | photons per pass | peak RSS (MiB), {where} | against the first "
          f"count | largest worker's peak (MiB) | peaks after passes {shown} (MiB) | "
          "s per pass |\n" + "| --- " * 8 + "|")
    key = "worker_peak_mib" if args.workers else "peak_mib"
    slopes = []
    for name, env in settings:
        firsts = []
        for photons in args.photons:
            rows = [run(args, photons, n, env) for n in args.passes]
            firsts.append(rows[0])
            for r in rows:
                marks = ", ".join(f"{v:.0f}" for v in r["peaks_at"].values()) or "-"
                worker = f"{r['worker_peak_mib']:.0f}" if args.workers else "-"
                print(f"| {name} | {r['passes']} | {photons:,} | {r['peak_mib']:.0f} | "
                      f"{r[key] / rows[0][key]:.3f} | {worker} | {marks} | "
                      f"{r['seconds'] / r['passes']:.2f} |", flush=True)
        for a, b in zip(firsts, firsts[1:]):
            grown = (b["stored"] / b["passes"] - a["stored"] / a["passes"])
            slopes.append((name, a, b, (b[key] - a[key]) * 2**20 / grown))
    if slopes:
        flight = 1 if args.workers or args.overlap == "off" else 2
        print(f"\n| environment | passes | photons stored a pass | bytes a stored photon | "
              f"a pass in flight ({flight} in flight) |\n" + "| --- " * 5 + "|")
        for name, a, b, slope in slopes:
            print(f"| {name} | {a['passes']} | {a['stored'] / a['passes']:,.0f} -> "
                  f"{b['stored'] / b['passes']:,.0f} | {slope:.0f} | {slope / flight:.0f} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
