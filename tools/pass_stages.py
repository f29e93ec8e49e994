"""Seconds per warm pass, stage by stage, of this checkout beside another commit's (a
``git worktree``), in the same run: each (checkout, scene, size, photons) a fresh process that
runs one pass at a time in one process (``run_passes`` on ``InProcess(overlap=False)``: one
pass in flight, no overlap; ``Renderer.step`` in a baseline older than ``run_passes``), leaves
out ``--warm`` passes and averages the next ``--passes``.

Per row: seconds a pass by stage (trace, index, photon radii, pixel splat, cover gather,
G-buffer + direct, caustic), photons stored per second of tracing, and stored photons per
second end to end (stored photons over the pass's total), with this checkout's ratio to the
baseline's on the line below each baseline row.

``--device`` is where this checkout traces its photons (``BLOCKHASH_DEVICE`` in its process:
``host``, the numba and embree tracer, or ``cpu``/``gpu``, the Dr.Jit kernels; default
``auto``); a baseline from before the device option traces on its own code whatever it says.
The trace stages are the caustic's (``trace``) and the indirect layer's (``indirect trace``).

``--indirect off`` leaves the indirect layer out (a baseline from before it had none), so
that both sides do the same work on scenes whose diffuse surfaces light one another.

usage: python tools/pass_stages.py --baseline /tmp/blockhash-6c34444
           [--scenes ring,venus,glass,corner] [--sizes 256,512] [--photons 200000,1000000]
           [--warm 1] [--passes 3] [--indirect on|off] [--device auto]
           [--json docs/pass-stages.json]
"""

import sys
from pathlib import Path

from blockhash.studies.command import ToolParser, count, in_checkout, write_json

ROOT = Path(__file__).resolve().parents[1]
STAGES = ("trace", "index", "photon radii", "pixel splat", "cover gather", "gbuffer", "direct",
          "caustic", "indirect trace", "total")

CHILD = r"""
import json, sys
import blockhash
scene_path, size, photons, warm, passes, indirect = sys.argv[1:7]
scene = blockhash.load_scene(scene_path).with_size(int(size), int(size))
import inspect
if "indirect" in inspect.signature(blockhash.Renderer).parameters:
    r = blockhash.Renderer(scene, photons=int(photons), indirect=indirect == "on")
else:  # a baseline from before the indirect layer
    r = blockhash.Renderer(scene, photons=int(photons))
rows = []
def keep(s):
    if len(rows) + int(warm) < r.passes:
        rows.append({"stored": s.stored, "emitted": s.emitted, "timings": s.timings})
try:  # one pass in flight, no overlap
    from blockhash.passes.executors import InProcess
    from blockhash.passes.run import run_passes
except ImportError:  # a baseline from before the render loop: one step at a time
    for p in range(int(warm) + int(passes)):
        keep(r.step())
else:
    run_passes(r, blockhash.RenderPlan(passes=int(warm) + int(passes),
                                       executor=InProcess(overlap=False)),
               on_pass=lambda renderer, s, elapsed, session: keep(s))
print(json.dumps(rows))
"""

def run(checkout: Path, scene: str, size: int, photons: int, warm: int, passes: int,
        indirect: str = "on", device: str = "auto") -> dict:
    rows = in_checkout(checkout, CHILD, [scene, size, photons, warm, passes, indirect], scene,
                       {"BLOCKHASH_DEVICE": device})
    n = len(rows)
    sec = {k: sum(r["timings"].get(k, 0.0) for r in rows) / n for k in STAGES}
    # the gather of every photon for the points seen in mirrors (a baseline from before its
    # own stage counts it in the caustic's)
    sec["cover gather"] += sum(r["timings"].get("mirror cover gather", 0.0) for r in rows) / n
    stored = sum(r["stored"] for r in rows) / n
    return {"seconds": sec, "stored": stored,
            "emitted": sum(r["emitted"] for r in rows) / n,
            "stored_per_trace_s": stored / sec["trace"] if sec["trace"] else None,
            "stored_per_s": stored / sec["total"]}


def main(argv=None):
    p = ToolParser(__doc__, __file__)
    p.add_argument("--baseline", type=Path, required=True, help="a checkout of the commit to "
                   "compare with (git worktree add /tmp/blockhash-6c34444 6c34444)")
    p.scenes("ring,venus,glass,corner")
    p.size([256, 512], many=True, flag="--sizes", help="image sides")
    p.photons([200_000, 1_000_000], many=True, help="photons per pass")
    p.add_argument("--warm", type=int, default=1, help="passes left out first (default 1)")
    p.add_argument("--passes", type=count, default=3, help="passes averaged (default 3)")
    p.add_argument("--indirect", choices=("on", "off"), default="on", help="the indirect layer "
                   "where the scene has it (on, the default) or left out")
    p.add_argument("--device", choices=("auto", "cpu", "gpu", "host"), default="auto",
                   help="where this checkout traces its photons (default auto)")
    p.json_output()
    args = p.parse_args(argv)
    cols = ("trace", "index", "photon radii", "pixel splat", "cover gather", "gbuffer + direct",
            "caustic", "indirect trace")
    print("| scene | size | photons | commit | s per pass | " + " | ".join(cols)
          + " | stored per s of tracing | stored per s end to end |")
    print("| --- " * (6 + len(cols) + 1) + "|")
    out = []
    for path in args.scenes:
        name, scene = path.stem, str(path)
        for size in args.sizes:
            for photons in args.photons:
                res = {}
                for label, checkout in (("baseline", args.baseline), ("this", ROOT)):
                    res[label] = run(checkout, scene, size, photons, args.warm, args.passes,
                                     args.indirect, args.device)
                    s = res[label]["seconds"]
                    vals = (s["trace"], s["index"], s["photon radii"], s["pixel splat"],
                            s["cover gather"], s["gbuffer"] + s["direct"], s["caustic"],
                            s["indirect trace"])
                    print(f"| {name} | {size} | {photons:,} | {label} | {s['total']:.3f} | "
                          + " | ".join(f"{v:.3f}" for v in vals)
                          + f" | {res[label]['stored_per_trace_s']:,.0f} | "
                            f"{res[label]['stored_per_s']:,.0f} |", flush=True)
                b, t = res["baseline"], res["this"]
                ratio = [b["seconds"][k] / t["seconds"][k] if t["seconds"][k] else float("nan")
                         for k in ("trace", "index", "photon radii", "pixel splat", "cover gather")]
                gd = ((b["seconds"]["gbuffer"] + b["seconds"]["direct"])
                      / (t["seconds"]["gbuffer"] + t["seconds"]["direct"]))
                ratio += [gd, b["seconds"]["caustic"] / t["seconds"]["caustic"],
                          (b["seconds"]["indirect trace"] / t["seconds"]["indirect trace"]
                           if t["seconds"]["indirect trace"] else float("nan"))]
                print(f"| {name} | {size} | {photons:,} | speed-up | "
                      f"{b['seconds']['total'] / t['seconds']['total']:.2f}x | "
                      + " | ".join(f"{r:.2f}x" for r in ratio)
                      + f" | {t['stored_per_trace_s'] / b['stored_per_trace_s']:.2f}x | "
                        f"{t['stored_per_s'] / b['stored_per_s']:.2f}x |", flush=True)
                out.append({"scene": name, "size": size, "photons": photons, **res})
    if args.json:
        write_json(args.json, {"args": vars(args), "rows": out})
    return 0


if __name__ == "__main__":
    sys.exit(main())
