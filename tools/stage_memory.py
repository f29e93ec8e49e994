"""Resident memory of each stage of a pass, in bytes a stored photon, of this checkout beside
another commit's (a ``git worktree``), in the same run.

Each checkout runs in a fresh process (``run_pass`` in this process: one pass in flight, no
overlap): pass 0, then pass 1 measured, after glibc's ``malloc_trim`` has handed the heap's free
memory back (else pass 1 reuses pass 0's freed arrays without growing, and a stage reads 0).  Before each stage of pass 1 the process's peak
resident set is reset (Linux: ``/proc/self/clear_refs``), after it the peak is read
(``VmHWM``): the row gives each stage's peak above the resident set at the start of the pass,
over the photons stored, and the resident set the stage leaves behind.  Stages: the trace, the
index, the photon radii, the pixel splat, the cover gather's build, and the estimate (the GL
caustic pass, with the gather of every photon for points seen in mirrors).

usage: python tools/stage_memory.py --baseline /tmp/blockhash-df31412
           [--scenes ring,glass] [--size 128] [--photons 1000000] [--json FILE]
"""

import sys
from pathlib import Path

from blockhash.studies.command import ToolParser, in_checkout, write_json

ROOT = Path(__file__).resolve().parents[1]
STAGES = ("trace", "index", "photon radii", "pixel splat", "cover gather", "estimate")

CHILD = r"""
import dataclasses, json, sys
import blockhash
import blockhash.passes.task as T

def status(key):
    with open("/proc/self/status") as f:
        return next(int(l.split()[1]) * 1024 for l in f if l.startswith(key + ":"))

rows, on = {}, [False]
def wrap(owner, attr, stage):
    f = getattr(owner, attr)
    def g(*a, **k):
        if not on[0]:
            return f(*a, **k)
        with open("/proc/self/clear_refs", "w") as c:
            c.write("5")  # the peak resident set starts again from now
        r = f(*a, **k)
        row = rows.setdefault(stage, {"peak": 0, "after": 0})
        row["peak"] = max(row["peak"], status("VmHWM") - start[0])
        row["after"] = status("VmRSS") - start[0]
        return r
    setattr(owner, attr, g)

for attr, stage in (("trace_pass", "trace"), ("BlockHashIndex", "index"),
                    ("PassRadii", "photon radii"), ("_split", "pixel splat"),
                    ("cover_gather", "cover gather")):
    wrap(T, attr, stage)
scene = blockhash.load_scene(sys.argv[1]).with_size(int(sys.argv[2]), int(sys.argv[2]))
setup = T.RenderSetup(scene, T.PassSettings.of(scene, photons=int(sys.argv[3]), indirect=False)
                      if "indirect" in T.PassSettings.__dataclass_fields__ else
                      T.PassSettings.of(scene, photons=int(sys.argv[3])))
holder = type("H", (), {})()
holder.estimate = setup.caustic.estimate
wrap(holder, "estimate", "estimate")
setup.caustic = dataclasses.replace(setup.caustic, estimate=holder.estimate)
first = T.run_pass(setup, 0)
emitted, first = first.emitted, None
import ctypes, gc
gc.collect()
ctypes.CDLL("libc.so.6").malloc_trim(0)  # the heap's free memory back: pass 1 grows from here
start = [status("VmRSS")]
on[0] = True
c = T.run_pass(setup, 1, emitted)
print(json.dumps({"stored": c.stored, "start": start[0], "stages": rows}))
"""


def run(checkout: Path, scene: str, size: int, photons: int) -> dict:
    return in_checkout(checkout, CHILD, [scene, size, photons], scene)


def main(argv=None):
    p = ToolParser(__doc__, __file__)
    p.add_argument("--baseline", type=Path, required=True, help="a checkout of the commit to "
                   "compare with (git worktree add /tmp/blockhash-df31412 df31412)")
    p.scenes("ring,glass")
    p.size(128)
    p.photons(1_000_000, help="photons a pass")
    p.json_output()
    args = p.parse_args(argv)
    if not Path("/proc/self/clear_refs").exists():
        raise SystemExit("tools/stage_memory.py reads Linux's /proc/self/clear_refs and VmHWM; "
                         "run it on Linux")
    print("| scene | commit | stored | " + " | ".join(f"{s}: peak (after)" for s in STAGES)
          + " |\n" + "| --- " * (3 + len(STAGES)) + "|")
    out = []
    for path in args.scenes:
        res = {}
        for label, checkout in (("baseline", args.baseline), ("this", ROOT)):
            res[label] = r = run(checkout, str(path.resolve()), args.size, args.photons)
            cells = []
            for s in STAGES:
                row = r["stages"].get(s)
                cells.append("-" if row is None else
                             f"{row['peak'] / r['stored']:.0f} ({row['after'] / r['stored']:.0f})")
            print(f"| {path.stem} | {label} | {r['stored']:,} | " + " | ".join(cells) + " |",
                  flush=True)
        out.append({"scene": path.stem, **res})
    print("\nbytes a stored photon above the resident set at the start of the pass")
    if args.json:
        write_json(args.json, {"args": vars(args), "rows": out})
    return 0


if __name__ == "__main__":
    sys.exit(main())
