"""Where a frame's time goes: cProfile of the frames of a camera orbit after the first.

Renders frame 0 of ``--frames`` frames of the scene's camera circling its target (one turn,
``--passes`` passes of ``--photons`` a frame, ``--size``, ``--spp``), then profiles frames 1 onward
(:func:`blockhash.passes.frames.render_frames`) and prints their seconds and the ``--top``
functions by cumulative time.

usage: python tools/profile_frames.py [SCENE] [--size 512] [--passes 1] [--photons 100000]
                                      [--spp 9] [--frames 3] [--top 30]
"""

import cProfile
import io
import pstats
import sys
from dataclasses import replace

from blockhash.passes.frames import render_frames
from blockhash.passes.plan import RenderPlan
from blockhash.scene.animation import Animation
from blockhash.scene.loader import load_scene
from blockhash.studies.command import ToolParser, count


def main(argv=None):
    p = ToolParser(__doc__, __file__)
    p.scenes("ring", many=False, flag="scene", nargs="?")
    p.size(512)
    p.add_argument("--passes", type=count, default=1, help="passes a frame")
    p.photons(100_000, help="photons a pass")
    p.add_argument("--spp", type=count, default=None,
                   help="samples a pixel (default the scene's)")
    p.add_argument("--frames", type=count, default=3, help="frames, the first not profiled")
    p.add_argument("--top", type=count, default=30, help="functions listed")
    args = p.parse_args(argv)
    scene = load_scene(args.scene).with_size(args.size, args.size)
    scene = replace(scene, animation=Animation(frames=args.frames, orbit=(1.0, None)))
    plan = RenderPlan(passes=args.passes)
    render_frames(scene, [0], photons=args.photons, spp=args.spp, plan=plan)
    profile = cProfile.Profile()
    profile.enable()
    seconds = render_frames(scene, range(1, args.frames), photons=args.photons, spp=args.spp,
                            plan=plan)
    profile.disable()
    print("seconds a frame: " + ", ".join(f"{f}: {s:.3f}" for f, s in seconds.items()))
    out = io.StringIO()
    pstats.Stats(profile, stream=out).sort_stats("cumulative").print_stats(args.top)
    print(out.getvalue())
    return 0


if __name__ == "__main__":
    sys.exit(main())
