"""The host's photon stages after the trace, one at a time, on the same photons, for this
checkout beside another commit's (a ``git worktree``), in the same run: the index's build
(its records' encode and its blocks), the photons' radii and the cover gather's build.

The photons are one pass's caustic photons of each scene, traced once here (``--photons``
emitted by the pass-0 rule, seed 1) and handed to a fresh process of each checkout, which
builds each stage once to warm it, then ``--repeat`` times, and prints the median seconds.
Each row also says whether the two checkouts built the same records, radii and gather (a
digest of each), so that a faster stage is seen to give the same result.

usage: python tools/photon_kernels.py --baseline /tmp/blockhash-437ace4
           [--scenes ring,glass] [--photons 200000] [--repeat 7] [--json docs/photon-kernels.json]
"""

import sys
import tempfile
from pathlib import Path

import numpy as np

from blockhash.studies.command import ToolParser, count, in_checkout, write_json

ROOT = Path(__file__).resolve().parents[1]
STAGES = ("encode", "blocks", "index", "radii", "cover build")

CHILD = r"""
import hashlib, json, sys, time
import numpy as np
from blockhash.frame.photon_radius import own_radii2
from blockhash.index.block_hash_index import BlockHashIndex
from blockhash.index.lookups.cover import CoverGather
data, repeat = np.load(sys.argv[1]), int(sys.argv[2])
build = lambda: BlockHashIndex(data["positions"], k=50, directions=data["directions"],
                               normals=data["normals"], powers=data["powers"], tables=False)
index = build()
r2 = own_radii2(index, 50)
gather = CoverGather.build(index, r2)
times = {s: [] for s in ("encode", "blocks", "index", "radii", "cover build")}
for _ in range(repeat):
    t = time.perf_counter(); index = build(); times["index"].append(time.perf_counter() - t)
    times["encode"].append(index.timings["encode"]); times["blocks"].append(index.timings["blocks"])
    t = time.perf_counter(); r2 = own_radii2(index, 50); times["radii"].append(time.perf_counter() - t)
    t = time.perf_counter(); gather = CoverGather.build(index, r2)
    times["cover build"].append(time.perf_counter() - t)
digest = lambda *a: hashlib.sha256(b"".join(np.ascontiguousarray(x).tobytes() for x in a)).hexdigest()[:16]
print(json.dumps({"seconds": {s: float(np.median(v)) for s, v in times.items()},
                  "records": digest(index.records.records, index.order), "radii": digest(r2),
                  "gather": digest(gather.records, gather.photon, gather.slots)}))
"""


def photons_file(scene: Path, photons: int, folder: Path) -> Path:
    """One pass's caustic photons of ``scene`` as an .npz file in ``folder``."""
    from blockhash.photons.tracing import trace_caustic_photons
    from blockhash.scene.loader import load_scene

    ph = trace_caustic_photons(load_scene(scene), photons, seed=1)
    path = folder / f"{scene.stem}.npz"
    np.savez(path, positions=ph.positions, directions=ph.directions, normals=ph.normals,
             powers=ph.powers)
    return path


def main(argv=None):
    p = ToolParser(__doc__, __file__)
    p.add_argument("--baseline", type=Path, required=True, help="a checkout of the commit to "
                   "compare with (git worktree add /tmp/blockhash-437ace4 437ace4)")
    p.scenes("ring,glass")
    p.photons([200_000], many=True, help="photons traced a scene (the pass-0 rule)")
    p.add_argument("--repeat", type=count, default=7, help="builds timed per stage (default 7)")
    p.json_output()
    args = p.parse_args(argv)
    print("| scene | photons | " + " | ".join(f"{s}: baseline -> this" for s in STAGES)
          + " | same result |")
    print("| --- " * (len(STAGES) + 3) + "|")
    out = []
    with tempfile.TemporaryDirectory() as folder:
        for scene in args.scenes:
            for photons in args.photons:
                path = photons_file(scene, photons, Path(folder))
                base, this = (in_checkout(c, CHILD, [path, args.repeat], path.stem)
                              for c in (args.baseline, ROOT))
                same = [k for k in ("records", "radii", "gather") if base[k] == this[k]]
                cells = [f"{base['seconds'][s]:.4f} -> {this['seconds'][s]:.4f} "
                         f"({base['seconds'][s] / this['seconds'][s]:.2f}x)" for s in STAGES]
                print(f"| {scene.stem} | {photons:,} | " + " | ".join(cells)
                      + f" | {', '.join(same) or 'none'} |", flush=True)
                out.append({"scene": scene.stem, "photons": photons, "baseline": base,
                            "this": this, "same": same})
    if args.json:
        write_json(args.json, {"args": vars(args), "rows": out})
    return 0


if __name__ == "__main__":
    sys.exit(main())
