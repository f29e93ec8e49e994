"""Regenerate the trade studies quoted in docs/tradeoff.md: ring and venus, JSON, plots, reports.

    python tools/tradeoff_study.py              # the full sweep (SweepPlan defaults), both scenes
    python tools/tradeoff_study.py --quick      # the one-minute sweep

Each scene's study goes to docs/tradeoff/<scene>/ (tradeoff.json, images.exr, *.png,
report.md; ``--out DIR`` puts them in DIR/<scene>/ instead); the light-traced references are
cached in ~/.cache/blockhash (by scene content), so a second run only re-renders.  Options it
does not know (``--photons 10000,100000``, ``--size 64x64``, ``--cache DIR``, ...) go to each
``blockhash tradeoff``.  Run it on an otherwise idle machine: every setting is timed.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

from blockhash.studies.command import ToolParser

ROOT = Path(__file__).resolve().parents[1]


def main(argv=None) -> int:
    parser = ToolParser(__doc__, __file__)
    parser.add_argument("--quick", action="store_true", help="the one-minute sweep of each scene")
    parser.scenes("ring,venus")
    parser.add_argument("--out", type=Path, default=ROOT / "docs" / "tradeoff",
                        help="folder of the studies, one folder per scene in it "
                             "(default: the checkout's docs/tradeoff)")
    args, extra = parser.parse_known_args(argv)
    for scene in args.scenes:
        cmd = [sys.executable, "-m", "blockhash", "tradeoff", str(scene),
               "-o", str(args.out.resolve() / scene.stem)] + (["--quick"] if args.quick else []) + extra
        print(" ".join(cmd), flush=True)
        code = subprocess.call(cmd)
        if code:
            return code
    return 0


if __name__ == "__main__":
    sys.exit(main())
