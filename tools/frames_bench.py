"""Frames at low latency: seconds a frame through the frame session beside another commit's
frames, flicker with and without common random numbers, and the memory of a camera-only
animation.

1. Latency: for each scene of ``--scenes``, size of ``--sizes`` and samples a pixel of
   ``--spp`` (one pass of ``--photons`` a frame): a camera orbit (``--frames`` frames of a full
   turn) and the scene's first light circling its target (one turn over the frames, 2 m out;
   an area light's object circles its place, :func:`circling`),
   each a fresh process that hands the frames' states one at a time to a
   :class:`~blockhash.passes.session.FrameSession`, the next after the last frame returned,
   writing no file (a ``--baseline`` checkout from before the session renders the same
   frames with its ``render_frames``).  Per row: the first frame's seconds (setup and
   compilation), the median of the later frames', of their GL gathers (the ``caustic`` and
   ``indirect estimate`` stages) and of the rest (a frame less its gathers), frames a second;
   and the ratio of this checkout's to the baseline's on the line below it.
2. Flicker: the ring's light moving each of ``--degrees`` a frame around it, the camera still, at
   ``--flicker-size``: each frame's caustic (``--flicker-photons`` a pass, one pass) with
   common random numbers (one seed for every frame) and with independent streams (seed + frame),
   against the light tracer's caustic of each frame (``--reference-photons``): the relative RMS,
   over the light tracer's comparison mask, of each frame-to-frame change less the
   reference's change, its median over the frames, and the ratio of the two.
3. Memory: the peak resident memory of a process rendering 1 and ``--memory-frames`` frames
   of the ring's camera orbit (``--memory-photons`` a pass, ``--memory-size``), and its
   resident memory after the last frame (what it holds between frames).

``--steps`` runs some of the three (default ``latency,flicker,memory``).

usage: python tools/frames_bench.py [--baseline /tmp/blockhash-d0deb7b] [--scenes ring,venus]
                                    [--sizes 256,512] [--spp 1,9] [--frames 6]
                                    [--photons 200000] [--degrees 1,0.1] [--flicker-frames 6]
                                    [--flicker-size 128] [--flicker-photons 100000]
                                    [--reference-photons 4000000] [--memory-frames 1,100]
                                    [--steps latency,flicker,memory] [--json FILE]
"""

import inspect
import math
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np

import blockhash
from blockhash.passes.plan import RenderPlan
from blockhash.reference.lighttrace import light_trace
from blockhash.scene.animation import Animation, Key
from blockhash.scene.loader import load_scene
from blockhash.studies.command import ToolParser, count, in_checkout, listing, write_json

ROOT = Path(__file__).resolve().parents[1]
#: The tool's steps (``--steps``).
STEPS = ("latency", "flicker", "memory")


def circling(scene, frames: int, degrees: float | None = None):
    """``scene`` with its first light circling the camera's target, 2 m out at the light's
    height: one turn over ``frames``, or ``degrees`` a frame (a key a frame).  An area light
    (which moves with its object) circles its own place instead, a tenth of the scene's size
    out: its object moves."""
    light = scene.lights[0]
    step = math.radians(360.0 / frames if degrees is None else degrees)
    turn = [(math.cos(math.pi + f * step), math.sin(math.pi + f * step)) for f in range(frames)]
    if not hasattr(light, "position"):  # an area light: its object moves
        lo, hi = np.asarray(scene.bounds[0]), np.asarray(scene.bounds[1])
        r = 0.1 * float(np.linalg.norm(hi - lo))
        keys = tuple(Key(f, {"translate": np.array([r * (c + 1.0), 0.0, r * s])})
                     for f, (c, s) in enumerate(turn))
        return replace(scene, animation=Animation(frames=frames, objects={light.object: keys}))
    target = scene.camera.target
    height = float(light.position[1])
    keys = tuple(Key(f, {"position": np.array([target[0] + 2.0 * c, height, target[2] + 2.0 * s])})
                 for f, (c, s) in enumerate(turn))
    return replace(scene, animation=Animation(frames=frames, lights={0: keys}))


def orbiting(scene, frames: int):
    return replace(scene, animation=Animation(frames=frames, orbit=(1.0, None)))


#: One checkout's frames in a fresh process (argv: scene, size, samples a pixel, photons,
#: frames, motion): a JSON list of [seconds, GL gather seconds] a frame.  The motions are
#: this tool's own functions, their source given to the child, which imports nothing of this
#: checkout (a baseline checkout's package lacks what this tool imports).
CHILD = """
import json, math, sys, time
from dataclasses import replace
import numpy as np
from blockhash.passes.plan import RenderPlan
from blockhash.scene.animation import Animation, Key
from blockhash.scene.loader import load_scene
""" + inspect.getsource(circling) + inspect.getsource(orbiting) + r"""
scene_path, size, spp, photons, frames, motion = sys.argv[1], *map(int, sys.argv[2:6]), sys.argv[6]
scene = load_scene(scene_path).with_size(size, size)
scene = orbiting(scene, frames) if motion == "camera orbit" else circling(scene, frames)
plan, rows = RenderPlan(passes=1), []
gather = lambda t: t.get("caustic", 0.0) + t.get("indirect estimate", 0.0)
try:
    from blockhash.passes.session import FrameSession
except ImportError:  # a checkout from before the session
    from blockhash.passes.frames import render_frames
    render_frames(scene, range(frames), photons=photons, spp=spp, plan=plan,
                  on_frame=lambda f, r, sec: rows.append([sec, gather(r.timings)]))
else:
    session = FrameSession(scene, photons=photons, spp=spp, plan=plan)
    for f in range(frames):
        session.frame(scene.animation.scene_at(scene, f))
        rows.append([session.seconds[-1], gather(session.last.timings)])
print(json.dumps(rows))
"""


def frames_of(checkout, path, size, spp, photons, frames, motion) -> dict:
    """One latency row of ``checkout``'s frames (a fresh process on its own code)."""
    rows = np.array(in_checkout(checkout, CHILD, [path, size, spp, photons, frames, motion],
                                "frames"))
    later = rows[1:] if len(rows) > 1 else rows
    frame, gather = float(np.median(later[:, 0])), float(np.median(later[:, 1]))
    return {"scene": Path(path).stem, "size": size, "spp": spp, "photons": photons,
            "motion": motion, "first": float(rows[0, 0]), "frame": frame, "gather": gather,
            "rest": float(np.median(later[:, 0] - later[:, 1])), "fps": 1.0 / frame}


def latency(path, size, spp, photons, frames, baseline) -> list[dict]:
    rows = []
    for motion in ("camera orbit", "light circling"):
        for commit, checkout in (("this", ROOT), ("baseline", baseline)):
            if checkout is None:
                continue
            rows.append({"commit": commit, **frames_of(checkout, path, size, spp, photons, frames,
                                                       motion)})
            r = rows[-1]
            print(f"{r['scene']} {size} {spp} spp {motion} {commit}: {r['frame']:.2f} s a frame "
                  f"(gather {r['gather']:.2f} s), first {r['first']:.2f} s", flush=True)
    return rows


def flicker(path, frames, size, photons, reference_photons, degrees) -> dict:
    scene = circling(load_scene(path).with_size(size, size), frames, degrees)
    refs, mask = [], None
    for f in range(frames):
        lt = light_trace(scene.animation.scene_at(scene, f), reference_photons)
        refs.append(lt.radiance)
        mask = lt.comparison_mask(1) if mask is None else mask & lt.comparison_mask(1)
    out = {"frames": frames, "size": size, "photons": photons, "degrees": degrees,
           "reference_photons": reference_photons}
    for label, seeds in (("common", [1] * frames), ("independent", [1 + f for f in range(frames)])):
        images = []
        for f in range(frames):
            one = scene.animation.scene_at(scene, f)
            images.append(blockhash.render(one, photons=photons, seed=seeds[f],
                                           plan=RenderPlan(passes=1)).caustic.astype(np.float64))
        changes = [np.sqrt((((images[f + 1] - images[f]) - (refs[f + 1] - refs[f]))[mask] ** 2).mean())
                   / refs[f][mask].mean() for f in range(frames - 1)]
        out[label] = float(np.median(changes))
    out["ratio"] = out["independent"] / out["common"]
    return out


MEMORY = """
import json, resource, sys
from dataclasses import replace
from blockhash.passes.frames import render_frames
from blockhash.passes.plan import RenderPlan
from blockhash.scene.animation import Animation
from blockhash.scene.loader import load_scene
scene = load_scene(sys.argv[1]).with_size(int(sys.argv[2]), int(sys.argv[2]))
n = int(sys.argv[3])
scene = replace(scene, animation=Animation(frames=n, orbit=(1.0, None)))
render_frames(scene, range(n), photons=int(sys.argv[4]), plan=RenderPlan(passes=int(sys.argv[5])))
with open("/proc/self/statm") as f:
    resident = int(f.read().split()[1]) * resource.getpagesize()
print(json.dumps([resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024, resident]))
"""


def memory(path, frames_list, size, photons, passes) -> list[dict]:
    rows = []
    for n in frames_list:
        peak, resident = in_checkout(ROOT, MEMORY, [path, size, n, photons, passes],
                                     f"{n} frames' memory")
        rows.append({"frames": n, "peak_bytes": peak, "resident_bytes": resident})
        print(f"memory {n} frames: peak {peak / 2**20:.0f} MiB, resident after the last "
              f"{resident / 2**20:.0f} MiB", flush=True)
    return rows


def tables(lat, flick, mem) -> str:
    out = ["| scene | size | spp | motion | commit | first frame s | a later frame s (median) "
           "| its GL gathers s | the rest s | frames a second |", "| --- " * 10 + "|"]
    base = {(r["scene"], r["size"], r["spp"], r["motion"]): r for r in lat
            if r["commit"] == "baseline"}
    for r in lat:
        out.append(f"| {r['scene']} | {r['size']} | {r['spp']} | {r['motion']} | {r['commit']} "
                   f"| {r['first']:.2f} | {r['frame']:.3f} | {r['gather']:.3f} | {r['rest']:.3f} "
                   f"| {r['fps']:.2f} |")
        b = base.get((r["scene"], r["size"], r["spp"], r["motion"]))
        if r["commit"] == "this" and b is not None:
            out.append(f"| | | | | this / baseline | {r['first'] / b['first']:.2f} | "
                       f"{r['frame'] / b['frame']:.2f} | {r['gather'] / b['gather']:.2f} | "
                       f"{r['rest'] / b['rest']:.2f} | |")
    if flick:
        out += ["", "| frames | size | photons | degrees a frame | frame-to-frame change less the "
                "reference's: common random numbers | independent streams | independent / common |",
                "| --- " * 7 + "|"]
        out += [f"| {f['frames']} | {f['size']} | {f['photons']:,} | {f['degrees']:g} | "
                   f"{f['common']:.4f} | {f['independent']:.4f} | {f['ratio']:.2f} |" for f in flick]
    if mem:
        out += ["", "| frames of a camera orbit | peak resident memory MiB | over one frame's "
                "| resident after the last frame MiB |",
                "| --- | --- | --- | --- |"]
        for r in mem:
            out.append(f"| {r['frames']} | {r['peak_bytes'] / 2**20:.0f} | "
                       f"{r['peak_bytes'] / mem[0]['peak_bytes']:.3f} | "
                       f"{r['resident_bytes'] / 2**20:.0f} |")
    return "\n".join(out)


def main(argv=None):
    p = ToolParser(__doc__, __file__)
    p.scenes("ring,venus")
    p.size([256, 512], many=True, flag="--sizes", help="image sizes")
    p.add_argument("--spp", type=listing(count), default=[1, 9],
                   help="samples a pixel of a frame's one pass (default 1,9)")
    p.add_argument("--baseline", type=Path, metavar="DIR",
                   help="a checkout of another commit (git worktree) whose frames run beside")
    p.add_argument("--frames", type=count, default=6, help="frames of each latency animation")
    p.photons(200_000, help="photons a pass of the latency renders")
    p.add_argument("--degrees", type=listing(float), default=[1.0, 0.1],
                   help="the light's turns a frame, a flicker row each (default 1,0.1)")
    p.add_argument("--flicker-frames", type=count, default=6)
    p.size(128, flag="--flicker-size", help="the flicker renders' size")
    p.photons(100_000, flag="--flicker-photons", help="photons of a flicker frame")
    p.photons(4_000_000, flag="--reference-photons", help="the light tracer's photons a frame")
    p.add_argument("--memory-frames", type=listing(count), default=[1, 100],
                   help="frame counts whose peak memory is measured (the first is the base)")
    p.size(256, flag="--memory-size", help="the memory renders' size")
    p.photons(1_000_000, flag="--memory-photons", help="photons a pass of the memory renders")
    p.add_argument("--steps", type=listing(str), default=list(STEPS),
                   help="which of latency, flicker, memory to run (default all)")
    p.json_output()
    args = p.parse_args(argv)
    unknown = set(args.steps) - set(STEPS)
    if unknown:
        p.error(f"--steps: unknown {sorted(unknown)}; give some of {','.join(STEPS)}")
    lat = [row for path in args.scenes for size in args.sizes for spp in args.spp
           for row in latency(path, size, spp, args.photons, args.frames, args.baseline)
           ] if "latency" in args.steps else []
    ring = p.scene("ring")
    flick = [flicker(ring, args.flicker_frames, args.flicker_size, args.flicker_photons,
                     args.reference_photons, d) for d in args.degrees
             ] if "flicker" in args.steps else []
    mem = memory(ring, args.memory_frames, args.memory_size, args.memory_photons, 1
                 ) if "memory" in args.steps else []
    if args.json:
        write_json(args.json, {"latency": lat, "flicker": flick, "memory": mem})
    print(tables(lat, flick, mem))
    return 0


if __name__ == "__main__":
    sys.exit(main())
