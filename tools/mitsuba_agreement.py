"""The project's light tracer against Mitsuba 3's reference, caustic layer (ks = 0 scenes).

For each scene: the light tracer (``--photons`` shot) and ``blockhash reference --engine
mitsuba``'s caustic (ptracer, albedos dimmed, ``--spp``) at ``--size``; their flux ratio
per channel on the light tracer's comparison mask (pixels seen through a mirror or glass
left out: neither reference connects a caustic to the pinhole through a delta surface), the light tracer's flux noise (from its
per-pixel standard errors), and the relative RMS of the two after a 5 x 5 box blur on the
caustic's pixels (blurred light tracer above 5% of its peak).

usage: python tools/mitsuba_agreement.py [--scenes ring,glass,venus] [--size 128]
                                         [--spp 1024] [--photons 4000000]
"""

import sys

import numpy as np

from blockhash.reference.lighttrace import light_trace
from blockhash.reference.mitsuba import mitsuba_reference, without_specular_lobes
from blockhash.scene.loader import load_scene
from blockhash.studies.command import ToolParser, count
from blockhash.studies.measure import box_blur_rel_rms


def main(argv=None):
    p = ToolParser(__doc__, __file__)
    p.scenes("ring,glass,venus")
    p.size(128)
    p.add_argument("--spp", type=count, default=1024, help="Mitsuba's samples per pixel")
    p.photons(4_000_000, help="photons the light tracer shoots")
    args = p.parse_args(argv)
    print("| scene | Mitsuba / light tracer flux (r, g, b) | light tracer flux noise | blurred "
          "relative RMS | Mitsuba s | light tracer s |\n| --- | --- | --- | --- | --- | --- |")
    for path in args.scenes:
        name = path.stem
        scene = without_specular_lobes(load_scene(path))
        size = (args.size, args.size)
        ref = mitsuba_reference(scene, args.spp, size=size, layers=("caustic",))
        lt = light_trace(scene, args.photons, size=size)
        mask = lt.comparison_mask(1)
        a, b = ref.caustic.astype(np.float64), lt.radiance
        ratio = a[mask].sum(axis=0) / b[mask].sum(axis=0)
        noise = np.sqrt((lt.stderr[mask] ** 2).sum(axis=0)) / b[mask].sum(axis=0)
        rel = box_blur_rel_rms(a, b, mask, bright=0.05)
        print(f"| {name} | {', '.join(f'{r:.4f}' for r in ratio)} | {noise.max():.4f} | "
              f"{rel:.4f} | {sum(ref.timings.values()):.2f} | {lt.stats.get('seconds', float('nan')):.2f} |",
              flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
