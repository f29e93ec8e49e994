"""Regenerate the trade studies quoted in docs/tradeoff.md: ring and venus, JSON, plots, reports.

    python tools/tradeoff_study.py              # the full sweep (SweepPlan defaults), both scenes
    python tools/tradeoff_study.py --quick      # the one-minute sweep

Each scene's study goes to docs/tradeoff/<scene>/ (tradeoff.json, images.exr, *.png,
report.md); the light-traced references are cached in ~/.cache/blockhash (by scene
content), so a second run only re-renders.  Run it on an otherwise idle machine: every
setting is timed.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true")
    parser.add_argument("--scenes", default="ring,venus")
    parser.add_argument("--out", default="docs/tradeoff", help="relative to the checkout's root")
    args, extra = parser.parse_known_args()
    for name in args.scenes.split(","):
        cmd = [sys.executable, "-m", "blockhash", "tradeoff", f"scenes/{name}.toml",
               "-o", str(Path(args.out) / name)] + (["--quick"] if args.quick else []) + extra
        print(" ".join(cmd), flush=True)
        code = subprocess.call(cmd, cwd=ROOT)
        if code:
            return code
    return 0


if __name__ == "__main__":
    sys.exit(main())
