"""The photon stages of whole passes on one device, in one process and on local workers: the
measurement the device pass is held to on a GPU machine, rehearsed anywhere on the CPU.

For each scene of ``--scenes`` at ``--size`` with ``--photons`` caustic photons a pass: a
render of ``--passes`` passes (after one untimed pass in the same process that compiles and
warms: numba's and Dr.Jit's caches, the GL context) on ``--device``, in this process and with
each count of ``--workers`` local worker processes.  Per run: the stored photons (caustic and
indirect) over the seconds of the photon stages (trace, index, photon radii, pixel splat, cover
gather, and the indirect layer's trace, index and radii), summed over the passes and the
processes; the caustic photons stored over the caustic's photon stages (its trace, index,
radii, splat and windows) and over the render's wall time (end to end); the indirect layer's
photon stages in seconds beside them.

usage: python tools/device_pass.py [--scenes ring,venus,cbox] [--size 512] [--photons 1e6]
                                   [--passes 4] [--workers 1,4,16] [--device auto] [--json FILE]
"""

import sys
import time

from blockhash.studies.command import ToolParser, count, listing, write_json

#: The stages of a pass's photons (the rest are the camera's: G-buffer, direct light, gathers).
PHOTON_STAGES = ("trace", "index", "photon radii", "pixel splat", "cover gather")


def one_run(scene, photons: int, passes: int, workers: int, device: str) -> dict:
    import blockhash
    from blockhash.passes.executors import InProcess, LocalWorkers

    executor = LocalWorkers(workers) if workers else InProcess()
    plan = blockhash.RenderPlan(passes=passes, executor=executor, device=device)
    t = time.perf_counter()
    image = blockhash.render(scene, photons=photons, plan=plan)
    wall = time.perf_counter() - t
    stages = dict(image.timings)
    photon_s = sum(v for k, v in stages.items() if k in PHOTON_STAGES)
    indirect_s = sum(v for k, v in stages.items()
                     if k.startswith("indirect ") and k != "indirect estimate")
    stored = int(image.info["photons_stored"])
    return {"workers": workers, "passes": image.passes, "wall_s": wall, "stages": stages,
            "photon_stages_s": photon_s, "indirect_photon_stages_s": indirect_s,
            "stored": stored, "device": image.info.get("device"),
            "stored_per_photon_s": stored / photon_s if photon_s else None,
            "stored_per_wall_s": stored / wall}


def main(argv=None) -> int:
    p = ToolParser(__doc__, __file__)
    p.scenes("ring,venus,cbox")
    p.size(512)
    p.photons(1_000_000)
    p.add_argument("--passes", type=count, default=4, help="passes a run (default 4)")
    p.add_argument("--workers", type=listing(int), default=[1, 4, 16],
                   help="local worker counts beside one process (default 1,4,16; 0: none)")
    p.add_argument("--device", choices=("auto", "cpu", "gpu", "host"), default="auto",
                   help="where the photons are traced (default auto)")
    p.json_output()
    args = p.parse_args(argv)
    import blockhash

    rows = []
    print("| scene | processes | passes | device | caustic stored | its photon stages s | stored "
          "per s of them | indirect photon stages s | wall s | stored per s end to end |")
    print("| --- | ---: | ---: | --- | ---: | ---: | ---: | ---: | ---: | ---: |")
    for path in args.scenes:
        scene = blockhash.load_scene(path).with_size(args.size, args.size)
        one_run(scene, args.photons, 1, 0, args.device)  # compiles and warms this process
        for workers in [0] + [w for w in args.workers if w > 0]:
            r = one_run(scene, args.photons, args.passes, workers, args.device)
            r["scene"] = path.stem
            rows.append(r)
            print(f"| {path.stem} | {'1 (in process)' if not workers else workers} | "
                  f"{r['passes']} | {r['device']} | {r['stored']:,} | {r['photon_stages_s']:.2f} | "
                  f"{r['stored_per_photon_s']:,.0f} | {r['indirect_photon_stages_s']:.2f} | "
                  f"{r['wall_s']:.2f} | "
                  f"{r['stored_per_wall_s']:,.0f} |", flush=True)
    if args.json:
        write_json(args.json, {"args": {k: str(v) for k, v in vars(args).items()}, "rows": rows})
    return 0


if __name__ == "__main__":
    sys.exit(main())
