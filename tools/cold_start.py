"""The first render with numba's and Dr.Jit's caches empty (cold) beside the same render with
them filled (warm).

Each repeat runs the command twice in turn, as a whole process: cold with ``NUMBA_CACHE_DIR``
a new empty folder and ``HOME`` another (Dr.Jit keeps its compiled kernels in ``~/.drjit``):
every compiled function and kernel is compiled and written there; then warm with folders that
an untimed run filled first.  ``--device`` is the render's ``BLOCKHASH_DEVICE``; ``--checkout``
runs another checkout's code (a ``git worktree``) for a render beside an earlier commit's.  Wall seconds of each, their ratio pair by pair, and
the render's own stages (its ``time:`` line) are printed as median, min and max.

    python tools/cold_start.py scenes/ring.toml --size 256x256 --repeat 5 [--device cpu]
                               [--checkout /tmp/blockhash-d0deb7b]

Nothing else is cleared between runs (Python's ``__pycache__``, the GL driver's shader cache):
the cold run is the first render after an install whose modules are already byte-compiled.
"""

from __future__ import annotations

import os
import re
import shutil
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

from blockhash.studies.command import ToolParser, count, timed, write_json

ROOT = Path(__file__).resolve().parents[1]


def run(command: list[str], cache: Path, extra_env: dict | None = None) -> tuple[float, dict[str, float]]:
    """(wall seconds, the render's stage seconds) of one run with numba's cache in ``cache``
    and Dr.Jit's under ``cache / "home"``."""
    (cache / "home").mkdir(parents=True, exist_ok=True)
    env = dict(os.environ, NUMBA_CACHE_DIR=str(cache), HOME=str(cache / "home"), **(extra_env or {}))
    done, wall = timed(subprocess.run, command, cwd=cache.parent, env=env, capture_output=True,
                       text=True)
    if done.returncode != 0:
        sys.exit(f"{' '.join(command)} failed ({done.returncode}):\n{done.stderr[-2000:]}")
    line = next((s for s in done.stdout.splitlines() if s.startswith("time: ")), "")
    stages = {name: float(sec) for name, sec in re.findall(r"([\w ]+?) ([\d.]+) s", line[6:])}
    return wall, {k.strip(): v for k, v in stages.items()}


def spread(values: list[float]) -> str:
    return f"{statistics.median(values):6.2f} {min(values):6.2f} {max(values):6.2f}"


def shown(path: Path) -> str:
    """``path`` relative to the checkout when it lies in it (scenes/ring.toml), else whole."""
    return str(path.relative_to(ROOT)) if path.is_relative_to(ROOT) else str(path)


def main(argv=None) -> int:
    parser = ToolParser(__doc__, __file__)
    parser.add_argument("scene", nargs="?", type=parser.scene, default="scenes/ring.toml",
                        help="scene file or name under scenes/ (default scenes/ring.toml)")
    parser.size("256x256", square=False)
    parser.add_argument("--photons", type=count,
                        help="photons per pass, passed to blockhash render (default: the scene's)")
    parser.add_argument("--repeat", type=count, default=5, help="cold/warm pairs (default 5)")
    parser.add_argument("--device", choices=("auto", "cpu", "gpu", "host"), default=None,
                        help="the render's device (BLOCKHASH_DEVICE; default: the environment's)")
    parser.add_argument("--checkout", type=Path, default=None,
                        help="run this checkout's code instead (PYTHONPATH), e.g. a worktree")
    parser.json_output("write every run's figures to this JSON file")
    args = parser.parse_args(argv)
    size = f"{args.size[0]}x{args.size[1]}"
    scene = shown(args.scene)

    work = Path(tempfile.mkdtemp(prefix="cold-start-"))
    command = [sys.executable, "-m", "blockhash", "render", str(args.scene), "--size", size,
               "-o", str(work / "out.exr")] + (["--photons", str(args.photons)] if args.photons else [])
    runs = {"cold": [], "warm": []}
    extra = {}
    if args.device:
        extra["BLOCKHASH_DEVICE"] = args.device
    if args.checkout:
        extra["PYTHONPATH"] = str(args.checkout.resolve())
    try:
        warm_cache = work / "warm"
        run(command, warm_cache, extra)  # fills the warm cache; untimed
        for i in range(args.repeat):
            cold_cache = work / f"cold-{i}"
            runs["cold"].append(run(command, cold_cache, extra))
            shutil.rmtree(cold_cache, ignore_errors=True)
            runs["warm"].append(run(command, warm_cache, extra))
            print(f"pair {i + 1}: cold {runs['cold'][-1][0]:.2f} s, warm {runs['warm'][-1][0]:.2f} s",
                  file=sys.stderr)
    finally:
        shutil.rmtree(work, ignore_errors=True)

    photons = f" --photons {args.photons}" if args.photons else ""
    where = f" ({args.checkout})" if args.checkout else ""
    device = f", device {args.device}" if args.device else ""
    print(f"blockhash render {scene} --size {size}{photons}{where}{device}: {args.repeat} pairs, "
          "cold then warm")
    print(f"{'seconds':<22} {'median':>6} {'min':>6} {'max':>6}")
    for kind in ("cold", "warm"):
        print(f"{kind + ' (whole process)':<22} {spread([w for w, _ in runs[kind]])}")
    ratios = [c[0] / w[0] for c, w in zip(runs["cold"], runs["warm"])]
    print(f"{'cold / warm':<22} {spread(ratios)}")
    stages = [s for s in runs["cold"][0][1] if all(s in r[1] for k in runs for r in runs[k])]
    for stage in stages:
        for kind in ("cold", "warm"):
            print(f"{kind + ' ' + stage:<22} {spread([r[1][stage] for r in runs[kind]])}")
    if args.json:
        write_json(args.json, {"command": command[1:], "device": args.device,
                               "checkout": str(args.checkout) if args.checkout else None,
                               "runs": runs, "ratios": ratios})
    return 0


if __name__ == "__main__":
    sys.exit(main())
