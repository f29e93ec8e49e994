"""Caustic photons traced alone, three ways on the same scene in the same process: blockhash's
host tracer (``device='host'``: numba's bookkeeping between embree's ray casts, float64), its
Dr.Jit kernels (``--device``, default ``cpu``: :mod:`blockhash.device`, emission and the bounce
loop in one symbolic kernel, float32) and the peer a user would pick, Mitsuba 3's particle
tracer (``ptracer``) rendering ``blockhash export`` of the scene at the same size.

For each scene of ``--scenes``: each tracer stores ``--photons`` photons
(:meth:`blockhash.photons.tracing.PhotonSource.until_stored`, the pass-0 rule), once cold (the
first run in the process: numba's and Dr.Jit's compilation or their disk caches) and then
``--repeat`` times with new seeds; the median's stored photons a second, stored per emitted and
caustic flux.  The source's setup (embree's BVH, the emitter's cones and projection maps, the
device's scene) is built once, outside the clock.  Mitsuba: the exported file at the scene's
``--size``, ``--spp`` light paths a pixel, the median of ``--repeat`` runs after one that
compiles, in light paths a second.

usage: python tools/trace_speed.py [--scenes ring,sun,cbox] [--photons 1000000] [--repeat 3]
                                   [--size 512] [--spp 16] [--device cpu] [--json FILE]
"""

import statistics
import sys
import tempfile
import time
from pathlib import Path

from blockhash.photons.tracing import PhotonSource
from blockhash.scene.loader import load_scene
from blockhash.scene.mitsuba.exporter import export_mitsuba
from blockhash.studies.command import ToolParser, count, write_json


def tracer_runs(scene, device: str, photons: int, repeat: int) -> dict:
    """``device``'s tracer: setup, a cold run, then ``repeat`` warm ones (seeds 2, 3, ...)."""
    t = time.perf_counter()
    source = PhotonSource(scene, device=device)
    setup = time.perf_counter() - t
    t = time.perf_counter()
    source.until_stored(photons, seed=1)
    cold = time.perf_counter() - t
    times, maps = [], []
    for r in range(repeat):
        t = time.perf_counter()
        maps.append(source.until_stored(photons, seed=2 + r))
        times.append(time.perf_counter() - t)
    sec = statistics.median(times)
    m = maps[times.index(sorted(times)[(len(times) - 1) // 2])]
    stored, emitted = len(m.positions), int(m.emitted)
    return {"device": source.device.name, "setup_s": setup, "cold_s": cold, "warm_s": times,
            "median_s": sec, "stored": stored, "emitted": emitted, "stored_per_s": stored / sec,
            "stored_per_emitted": stored / emitted, "rays_cast": int(m.stats.get("rays_cast", 0)),
            "flux": [float(x) for x in m.total_power]}


def ptracer_runs(scene, size: int, spp: int, repeat: int) -> dict:
    """Mitsuba's particle tracer on the exported scene: light paths a second."""
    from blockhash.reference.mitsuba import load_mitsuba_module

    mi, variant = load_mitsuba_module()
    import drjit as dr

    with tempfile.TemporaryDirectory(prefix="trace-speed-") as tmp:
        xml = export_mitsuba(scene.with_size(size, size), Path(tmp), drop_specular=True)
        mscene = mi.load_file(str(xml))
        times = []
        for r in range(repeat + 1):
            t = time.perf_counter()
            image = mi.render(mscene, spp=spp, seed=r)
            dr.eval(image)
            dr.sync_thread()
            times.append(time.perf_counter() - t)
    sec = statistics.median(times[1:])
    return {"variant": variant, "size": size, "spp": spp, "median_s": sec,
            "paths_per_s": spp * size * size / sec}


def main(argv=None) -> int:
    p = ToolParser(__doc__, __file__)
    p.scenes("ring,sun,cbox")
    p.add_argument("--photons", type=count, default=1_000_000,
                   help="stored photons each run aims at (default 1,000,000)")
    p.add_argument("--repeat", type=count, default=3, help="warm runs, median kept (default 3)")
    p.size(512, help="the peer's image side")
    p.add_argument("--spp", type=count, default=16, help="the peer's light paths a pixel "
                   "(default 16)")
    p.add_argument("--device", choices=("cpu", "gpu"), default="cpu",
                   help="the Dr.Jit device of the kernels (default cpu)")
    p.json_output()
    args = p.parse_args(argv)
    rows = []
    for path in args.scenes:
        scene = load_scene(path)
        host = tracer_runs(scene, "host", args.photons, args.repeat)
        kern = tracer_runs(scene, args.device, args.photons, args.repeat)
        peer = ptracer_runs(scene, args.size, args.spp, args.repeat)
        rows.append({"scene": path.stem, "photons": args.photons, "repeat": args.repeat,
                     "host": host, "kernels": kern, "ptracer": peer,
                     "kernels_over_host": kern["stored_per_s"] / host["stored_per_s"],
                     "kernels_over_peer": kern["stored_per_s"] / peer["paths_per_s"]})
        print(f"{path.stem}: host {host['stored_per_s']:,.0f}/s, kernels "
              f"{kern['stored_per_s']:,.0f}/s, ptracer {peer['paths_per_s']:,.0f} paths/s",
              file=sys.stderr)
    print(f"\nCaustic photons traced alone, {args.photons:,} stored a run, median of "
          f"{args.repeat} warm runs; the peer at {args.size} x {args.size}, {args.spp} spp\n")
    print("| scene | host stored/s | kernels stored/s | kernels / host | ptracer paths/s | "
          "kernels / ptracer | stored / emitted (host, kernels) | cold s (host, kernels) |")
    print("| --- | ---: | ---: | ---: | ---: | ---: | --- | --- |")
    for r in rows:
        h, k, m = r["host"], r["kernels"], r["ptracer"]
        print(f"| {r['scene']} | {h['stored_per_s']:,.0f} | {k['stored_per_s']:,.0f} | "
              f"{r['kernels_over_host']:.2f}x | {m['paths_per_s']:,.0f} | "
              f"{r['kernels_over_peer']:.2f}x | {h['stored_per_emitted']:.3f}, "
              f"{k['stored_per_emitted']:.3f} | {h['cold_s']:.2f}, {k['cold_s']:.2f} |")
    if args.json:
        write_json(args.json, {"rows": rows})
    return 0


if __name__ == "__main__":
    sys.exit(main())
