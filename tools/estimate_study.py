"""Measure the caustic density estimate's options against the light-traced reference.

    python tools/estimate_study.py                        # ring, venus, corner; N = 1e5, 1e6; k = 50
    python tools/estimate_study.py --scenes corner --photons 100000 --ks 50,100 --size 96

Every Phong ks is set to 0 (Lambertian receivers).  For each scene, N and k one photon
map and one Block Hashing search per pixel; every option of
blockhash.tradeoff.estimates.default_options() is evaluated on those neighbours.  Prints
one line per row, writes the rows as JSON (--json) and the markdown tables (--markdown;
--from-json FILE prints them again from a saved study).
References are cached in ~/.cache/blockhash by scene content (the first run traces them).
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))


def _ints(text):
    return tuple(int(float(x)) for x in text.split(","))


def main() -> int:
    from blockhash.render import scene_toml
    from blockhash.tradeoff.estimates import (markdown_table, option_table, study_scene,
                                              summary_table)

    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--scenes", default="ring,venus,corner", help="names under scenes/")
    p.add_argument("--photons", type=_ints, default=(100_000, 1_000_000))
    p.add_argument("--ks", type=_ints, default=(50,))
    p.add_argument("--size", type=int, default=128, help="image width and height (default 128)")
    p.add_argument("--supersample", type=int, default=2,
                   help="shading points per pixel along each axis (default 2)")
    p.add_argument("--reference-photons", type=int, default=50_000_000)
    p.add_argument("--cache", default=str(Path.home() / ".cache" / "blockhash"))
    p.add_argument("--json", help="write the studies here")
    p.add_argument("--markdown", help="write the tables here")
    p.add_argument("--from-json", help="only print the tables of a study written by --json")
    args = p.parse_args()
    studies = json.loads(Path(args.from_json).read_text()) if args.from_json else []
    for name in [] if args.from_json else args.scenes.split(","):
        scene = scene_toml.load_scene(ROOT / "scenes" / f"{name}.toml")
        studies.append(study_scene(scene, photons=args.photons, ks=args.ks,
                                   size=(args.size, args.size), supersample=args.supersample,
                                   reference_photons=args.reference_photons, cache_dir=args.cache,
                                   progress=lambda s: print(s, flush=True)))
        print(f"reference noise (region, per pixel): {studies[-1]['reference']}", flush=True)
        if args.json:
            Path(args.json).write_text(json.dumps(studies, indent=1))
    ks = sorted({r["k"] for st in studies for r in st["rows"]})
    k0 = 50 if 50 in ks else ks[0]
    table = ("Each option, flux / blurred relative RMS, whole compared area:\n\n"
             + option_table(studies, k0) + "\n\nThe same in the caustic region:\n\n"
             + option_table(studies, k0, region=True)
             + "\n\nDefault against the paper's estimate:\n\n" + summary_table(studies)
             + "\n\nEvery option:\n\n" + markdown_table(studies))
    print(table)
    if args.markdown:
        Path(args.markdown).write_text(table + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
