"""Measure the caustic density estimate's options against the light-traced reference.

    python tools/estimate_study.py                        # ring, venus, corner; N = 1e5, 1e6; k = 50
    python tools/estimate_study.py --scenes corner --photons 100000 --ks 50,100 --size 96
    python tools/estimate_study.py --done-when --json docs/radiance-estimate-done-when.json

Every Phong ks is set to 0 (Lambertian receivers).  For each scene, N and k one photon
map and one Block Hashing search per shading point; every option of
blockhash.studies.density.estimates.default_options() is evaluated on those neighbours.  Prints
one line per row, writes the rows as JSON (--json) and the markdown tables (--markdown;
--from-json FILE prints them again from a saved study).  --jitter SEED places the shading
points by stratified jitter instead of the rasterised grid.

--done-when is the issue's check (blockhash.studies.density.sampling): ring, venus and corner at
N = 10^6, k = 50, pixel means from 8 x 8 jittered shading points per pixel with the 100
most uneven pixels estimated again at 32 x 32, over jitter seeds 1 to 8, the paper's
estimate and the default, with each measure's mean and standard error over the seeds.
References are cached in ~/.cache/blockhash by scene content (the first run traces them).
"""

from __future__ import annotations

import json
from pathlib import Path

from blockhash.scene.loader import load_scene
from blockhash.studies.command import ToolParser, count, listing, side, write_json
from blockhash.studies.density.estimates import (
    default_options,
    markdown_table,
    option_table,
    reference_options,
    study_scene,
    summary_table,
)
from blockhash.studies.density.sampling import context_table, done_when_study, done_when_table


def _done_when(args, studies):
    for path in [] if args.from_json else args.scenes:
        scene = load_scene(path)
        for n in args.photons or (1_000_000,):
            studies.append(done_when_study(
                scene, photons=n, ks=args.ks or (50,), size=(args.size, args.size),
                samples=args.supersample or 8, seeds=args.seeds, refine=args.refine,
                refine_samples=args.refine_samples, search_kinds=args.search.split(","),
                estimate_options=default_options() if args.all_options else None,
                reference_photons=args.reference_photons, cache_dir=args.cache,
                progress=lambda s: print(s, flush=True)))
            if args.json:
                write_json(args.json, studies)
    return ("Done-when check (jittered pixel means, mean ± standard error over seeds):\n\n"
            + done_when_table(studies) + "\n\nWhat the rows rest on:\n\n" + context_table(studies))


def main(argv=None) -> int:
    p = ToolParser(__doc__, __file__)
    p.scenes("ring,venus,corner")
    p.add_argument("--photons", type=listing(count), default=None,
                   help="photons stored (default 100000,1000000; --done-when 1000000)")
    p.add_argument("--ks", type=listing(count), default=None, help="k (default 50)")
    p.add_argument("--size", type=side, default=128,
                   help="image width and height, 128 or 128x128 (default 128)")
    p.add_argument("--supersample", type=count, default=None,
                   help="shading points per pixel along each axis (default 2; --done-when 8)")
    p.add_argument("--jitter", type=int, default=None,
                   help="seed of stratified jittered shading points (default: the rasterised grid)")
    reference_options(p, 50_000_000, flag="--reference-photons")
    p.add_argument("--json", type=Path, help="write the studies here")
    p.add_argument("--markdown", type=Path, help="write the tables here")
    p.add_argument("--from-json", type=Path,
                   help="only print the tables of a study written by --json")
    g = p.add_argument_group("the done-when check")
    g.add_argument("--done-when", action="store_true", help="run (or, with --from-json, print) it")
    g.add_argument("--seeds", type=listing(int), default=list(range(1, 9)),
                   help="jitter seeds (default 1,...,8)")
    g.add_argument("--refine", type=int, default=100, help="pixels estimated again (default 100)")
    g.add_argument("--refine-samples", type=count, default=32,
                   help="their shading points per pixel along each axis (default 32)")
    g.add_argument("--search", default="bh", help="bh, exact or bh,exact (default bh)")
    g.add_argument("--all-options", action="store_true",
                   help="every option of the study, not only the paper's and the default")
    args = p.parse_args(argv)
    studies = json.loads(args.from_json.read_text()) if args.from_json else []
    if args.done_when:
        table = _done_when(args, studies)
    else:
        for path in [] if args.from_json else args.scenes:
            studies.append(study_scene(load_scene(path), photons=args.photons or (100_000, 1_000_000),
                                       ks=args.ks or (50,), size=(args.size, args.size),
                                       supersample=args.supersample or 2, jitter=args.jitter,
                                       reference_photons=args.reference_photons,
                                       cache_dir=args.cache, progress=lambda s: print(s, flush=True)))
            print(f"reference noise (region, per pixel): {studies[-1]['reference']}", flush=True)
            if args.json:
                write_json(args.json, studies)
        ks = sorted({r["k"] for st in studies for r in st["rows"]})
        k0 = 50 if 50 in ks else ks[0]
        table = ("Each option, flux / blurred relative RMS, whole compared area:\n\n"
                 + option_table(studies, k0) + "\n\nThe same in the caustic region:\n\n"
                 + option_table(studies, k0, region=True)
                 + "\n\nDefault against the paper's estimate:\n\n" + summary_table(studies)
                 + "\n\nEvery option:\n\n" + markdown_table(studies))
    print(table)
    if args.markdown:
        args.markdown.write_text(table + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
