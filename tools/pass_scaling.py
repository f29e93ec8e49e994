"""Passes per second and stored photons per second of a render against where its passes run:
in this process, local worker processes, a Dask LocalCluster; each configuration a whole fresh
process, side by side in one run, each image's largest difference to the in-process render.

Warm throughput leaves out the first ``--warm`` passes (a process's start, its GL context,
compiled programs and numba's cache loading, pass 0 alone): stored photons of passes
``warm..N-1`` over the time from the end of pass ``warm - 1`` to the end of pass ``N - 1``.
``--baseline DIR`` adds the in-process render of another checkout (e.g. a ``git worktree``
of an earlier commit), a pass at a time (``Renderer.step``, which every commit with passes
has), as the row the ratios are against.

usage: python tools/pass_scaling.py [--scenes ring,venus] [--sizes 256,512]
           [--photons 200000] [--passes 12] [--warm 2] [--workers 1,2] [--dask 2]
           [--baseline /tmp/blockhash-6c34444] [--json docs/pass-scaling.json]
"""

import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

from blockhash.studies.command import ToolParser, count, listing, write_json

ROOT = Path(__file__).resolve().parents[1]

#: One configuration in a fresh process: prints JSON (pass end times, stored photons, CPU).
CHILD = r"""
import json, resource, sys, time
t_start = time.perf_counter()
import numpy as np
import blockhash
scene_path, size, photons, passes, kind, count, out = sys.argv[1:8]
size, photons, passes, count = int(size), int(photons), int(passes), int(count)
scene = blockhash.load_scene(scene_path).with_size(size, size)
ends, stored = [], []
t0 = time.perf_counter()
cluster = None
if kind == "step":  # any commit's API: one pass at a time, in this process
    r = blockhash.Renderer(scene, photons=photons)
    while r.passes < passes:
        s = r.step()
        ends.append(time.perf_counter() - t0)
        stored.append(s.stored)
else:
    from blockhash.passes.run import run_passes
    if kind == "inprocess":
        from blockhash.passes.executors import InProcess
        executor = InProcess()
    elif kind == "workers":
        from blockhash.passes.executors import LocalWorkers
        executor = LocalWorkers(count)
    else:
        from distributed import LocalCluster
        from blockhash.passes.dask_cluster import DaskCluster
        cluster = LocalCluster(n_workers=count, threads_per_worker=1, processes=True,
                               dashboard_address=":0")
        t0 = time.perf_counter()
        executor = DaskCluster(cluster.scheduler_address)
    r = blockhash.Renderer(scene, photons=photons)
    def on_pass(renderer, stats, elapsed, session):
        ends.append(time.perf_counter() - t0)
        stored.append(stats.stored)
    run_passes(r, blockhash.RenderPlan(passes=passes, executor=executor), on_pass=on_pass)
img = r.image
np.savez(out, direct=img.direct, caustic=img.caustic)
if cluster is not None:
    cluster.close()
self_ru, kids = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
print(json.dumps({"ends": ends, "stored": stored, "emitted": int(r.emitted),
                  "process_s": time.perf_counter() - t_start,
                  "cpu_s": self_ru.ru_utime + self_ru.ru_stime + kids.ru_utime + kids.ru_stime,
                  "peak_mib": self_ru.ru_maxrss / 1024}))
"""


def run_child(checkout: Path, scene: str, size: int, photons: int, passes: int, kind: str,
              count: int, out: Path) -> dict:
    env = {**os.environ, "PYTHONPATH": str(checkout)}
    proc = subprocess.run([sys.executable, "-c", CHILD, scene, str(size), str(photons),
                           str(passes), kind, str(count), str(out)],
                          capture_output=True, text=True, env=env, cwd=tempfile.gettempdir())
    if proc.returncode:
        raise SystemExit(f"{kind} {count} on {scene} failed:\n{proc.stderr[-3000:]}")
    return json.loads(proc.stdout.strip().splitlines()[-1])


def warm_rates(result: dict, warm: int) -> tuple[float, float]:
    """(passes per second, stored photons per second) of passes ``warm..N-1``."""
    ends, stored = result["ends"], result["stored"]
    span = ends[-1] - ends[warm - 1]
    return (len(ends) - warm) / span, sum(stored[warm:]) / span


def main(argv=None):
    p = ToolParser(__doc__, __file__)
    p.scenes("ring,venus")
    p.size([256, 512], many=True, flag="--sizes")
    p.photons(200_000, help="photons stored per pass")
    p.add_argument("--passes", type=count, default=12)
    p.add_argument("--warm", type=count, default=2, help="passes left out of the warm rates")
    p.add_argument("--workers", type=listing(count), default=[1, 2],
                   help="local worker counts ('' for none)")
    p.add_argument("--dask", type=listing(count), default=[2],
                   help="Dask LocalCluster worker counts ('' for none)")
    p.add_argument("--baseline", type=Path, help="a checkout of another commit: its in-process "
                   "render is the row the ratios are against")
    p.json_output()
    args = p.parse_args(argv)
    if not 1 <= args.warm < args.passes:
        p.error(f"--warm {args.warm}: leave out at least 1 and fewer than --passes {args.passes}")
    configs = ([("inprocess", 1)] + [("workers", n) for n in args.workers]
               + [("dask", n) for n in args.dask])
    rows = []
    print("| scene | size | executor | process s | CPU s | warm passes/s | warm stored photons/s "
          "| against the baseline | largest difference to in-process |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- | --- |")
    with tempfile.TemporaryDirectory() as tmp:
        for path in args.scenes:
            scene, name = str(path), path.stem
            for size in args.sizes:
                runs = []
                if args.baseline:
                    runs.append(("baseline in process", args.baseline, "step", 1))
                runs += [(_label(kind, n), ROOT, kind, n) for kind, n in configs]
                base_rate, ref = None, None
                for label, checkout, kind, n in runs:
                    out = Path(tmp) / f"{len(rows)}.npz"
                    result = run_child(checkout, scene, size, args.photons, args.passes, kind, n, out)
                    pps, photons_s = warm_rates(result, args.warm)
                    image = np.load(out)
                    if kind == "inprocess" and checkout == ROOT:
                        ref = image
                    diff = (max(float(np.abs(image[k] - ref[k]).max()) for k in ("direct", "caustic"))
                            if ref is not None else None)
                    base_rate = base_rate or photons_s
                    row = {"scene": name, "size": size, "executor": label, **result,
                           "warm_passes_per_s": pps, "warm_photons_per_s": photons_s,
                           "ratio": photons_s / base_rate, "max_diff": diff}
                    rows.append(row)
                    print(f"| {name} | {size} | {label} | {result['process_s']:.1f} | "
                          f"{result['cpu_s']:.1f} | {pps:.2f} | {photons_s:,.0f} | "
                          f"{photons_s / base_rate:.2f}x | "
                          f"{'-' if diff is None else f'{diff:.3g}'} |", flush=True)
    if args.json:
        write_json(args.json, {"args": {k: str(v) for k, v in vars(args).items()}, "rows": rows})


def _label(kind: str, n: int) -> str:
    return {"inprocess": "in process", "workers": f"{n} local worker{'s' if n > 1 else ''}",
            "dask": f"Dask LocalCluster, {n} worker{'s' if n > 1 else ''}"}[kind]


if __name__ == "__main__":
    main()
