"""The GPU's image is the CPU's: every canonical scene rendered by the GL gather on this
device and by the CPU reference of the same estimate (``--method cpu``) at the same seed,
each layer finite and the two within the tolerance the GL-against-CPU tests use
(tests/frame/test_cover_estimate.py: |gl - cpu| <= 2e-5 |cpu| + 1e-6 max|cpu| per value);
then the Cornell box render that was NaN on an NVIDIA H200 (512 x 512, 8 passes, 16 local
workers), checked finite.

    python tools/gpu_conformance.py                        # 256 x 256, 2 passes, every scene
    python tools/gpu_conformance.py --size 64 --photons 20000 --box-size 64 --box-workers 2
    bash .whl/run.sh python3 $PWD/tools/gpu_conformance.py --json $OUT/conformance.json  # GPU

``--strict`` renders the GL side in strict GL (blockhash/gl/strict.py: textures poisoned,
GLSL's undefined operations NaN), which is how llvmpipe shows what a GPU may do.  Prints a
table (the device's GL renderer and version first) and exits 1 where a scene is not finite
or not within tolerance.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
SCENES = ("ring", "venus", "glass", "corner", "mirror", "cbox", "sun")
#: The GL-against-CPU tests' tolerance (tests/frame/test_cover_estimate.py).
RTOL, ATOL = 2e-5, 1e-6


def compare(gl: np.ndarray, cpu: np.ndarray) -> dict:
    """One layer: finite on each side, the largest relative difference, the values beyond
    tolerance."""
    finite = bool(np.isfinite(gl).all()), bool(np.isfinite(cpu).all())
    scale = float(np.abs(cpu).max()) if finite[1] and cpu.size else 0.0
    diff = np.abs(gl.astype(np.float64) - cpu)
    over = int((diff > RTOL * np.abs(cpu) + ATOL * scale).sum()) if all(finite) else -1
    rel = float(diff.max() / scale) if all(finite) and scale > 0 else 0.0
    return {"gl_finite": finite[0], "cpu_finite": finite[1], "max_rel": rel, "over": over,
            "ok": all(finite) and over == 0}


def scene_rows(name: str, args) -> list[dict]:
    import blockhash
    from blockhash import LookupOptions, RenderPlan
    from blockhash.gl.strict import strict

    scene = blockhash.load_scene(ROOT / "scenes" / f"{name}.toml").with_size(args.size, args.size)
    images, seconds = {}, {}
    for method in ("auto", "cpu"):
        t = time.perf_counter()
        with strict(args.strict and method == "auto"):
            images[method] = blockhash.render(scene, photons=args.photons, seed=args.seed,
                                              lookup=LookupOptions(method=method),
                                              plan=RenderPlan(passes=args.passes)).layers()
        seconds[method] = time.perf_counter() - t
    rows = []
    for layer, cpu in images["cpu"].items():
        rows.append({"scene": name, "layer": layer, **compare(images["auto"][layer], cpu),
                     "gl_s": seconds["auto"], "cpu_s": seconds["cpu"]})
    return rows


def box_render(args) -> dict:
    """The reported command: the Cornell box on local workers, its EXR's layers finite."""
    from blockhash.evaluate.images import read_layers

    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "cbox.exr"
        cmd = [sys.executable, "-m", "blockhash", "render", str(ROOT / "scenes" / "cbox.toml"),
               "--size", f"{args.box_size}x{args.box_size}", "--passes", str(args.box_passes),
               "--workers", str(args.box_workers), "-o", str(out)]
        shown = ("blockhash render scenes/cbox.toml " + " ".join(cmd[5:-2])).strip()
        t = time.perf_counter()
        run = subprocess.run(cmd, capture_output=True, text=True)
        seconds = time.perf_counter() - t
        if run.returncode != 0 or not out.is_file():
            return {"command": shown, "ok": False, "seconds": seconds,
                    "error": (run.stderr or run.stdout)[-2000:]}
        layers = read_layers(out)
        bad = {k: int((~np.isfinite(v)).sum()) for k, v in layers.items()}
    return {"command": shown, "seconds": seconds,
            "non_finite": bad, "ok": not any(bad.values())}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--scenes", default=",".join(SCENES), help="comma-separated scene names")
    ap.add_argument("--size", type=int, default=256, help="image side (pixels)")
    ap.add_argument("--passes", type=int, default=2)
    ap.add_argument("--photons", type=int, default=100_000, help="photons stored per pass")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--strict", action="store_true", help="the GL side in strict GL")
    ap.add_argument("--box-size", type=int, default=512)
    ap.add_argument("--box-passes", type=int, default=8)
    ap.add_argument("--box-workers", type=int, default=16, help="0: leave the box render out")
    ap.add_argument("--json", help="write the rows here")
    args = ap.parse_args(argv)

    from blockhash.gl.context import get_context

    ctx = get_context()
    device = {"renderer": ctx.info["GL_RENDERER"], "version": ctx.info["GL_VERSION"]}
    print(f"device: {device['renderer']}; GL {device['version']}"
          + ("; strict GL" if args.strict else ""))
    print(f"{args.size} x {args.size}, {args.passes} passes, {args.photons:,} photons a pass, "
          f"seed {args.seed}; tolerance |gl - cpu| <= {RTOL:g} |cpu| + {ATOL:g} max|cpu|")
    print(f"{'scene':8} {'layer':9} {'GL finite':>9} {'CPU finite':>10} {'max rel diff':>12} "
          f"{'over tol':>8} {'GL s':>6} {'CPU s':>6}  verdict")
    rows = []
    for name in args.scenes.split(","):
        for row in scene_rows(name, args):
            rows.append(row)
            print(f"{row['scene']:8} {row['layer']:9} {str(row['gl_finite']):>9} "
                  f"{str(row['cpu_finite']):>10} {row['max_rel']:12.2e} {row['over']:8d} "
                  f"{row['gl_s']:6.1f} {row['cpu_s']:6.1f}  {'ok' if row['ok'] else 'FAIL'}")
    box = box_render(args) if args.box_workers > 0 else None
    if box is not None:
        print(f"{box['command']}: {box['seconds']:.1f} s, "
              + (f"non-finite values per layer {box['non_finite']}" if "non_finite" in box
                 else f"failed: {box['error']}") + f"  {'ok' if box['ok'] else 'FAIL'}")
    if args.json:
        Path(args.json).write_text(json.dumps({"device": device, "args": vars(args), "rows": rows,
                                               "box": box}, indent=1))
    return 0 if all(r["ok"] for r in rows) and (box is None or box["ok"]) else 1


if __name__ == "__main__":
    sys.exit(main())
