"""A GPU compiler's view of the shaders blockhash runs: registers, scratch memory, occupancy
(what ``tools/shader_stats.py`` prints and ``tests/studies/shaders/test_gpu_compiler.py`` holds to budget).

Mesa's RADV Vulkan driver compiles pipelines on a null device, with no GPU
(``RADV_FORCE_FAMILY``).  :func:`lookup_shaders` and :func:`caustic_shaders` record the
fragment shaders that the lookup (``GLLookup.query``), the exact kd-tree shader and the caustic
pass really hand the GL driver (``blockhash.gl.shaderlib.recording``; llvmpipe compiles them as
usual); :func:`compile_stats` turns each into SPIR-V with glslang's relaxed GL rules (no text
changed) and reads ACO's statistics through ``pipeline_stats.c`` beside this module (built on
first use into the cache folder).  Needs glslangValidator, a C compiler, the Vulkan headers and
loader and Mesa's RADV ICD (Debian: glslang-tools gcc libvulkan-dev mesa-vulkan-drivers);
:func:`available` says what is missing.
"""

from __future__ import annotations

import copy
import hashlib
import os
import shutil
import subprocess
import tempfile
import warnings
from dataclasses import replace
from pathlib import Path

import numpy as np

#: The Vulkan program that reads ACO's statistics of a pipeline (built on first use).
C_SOURCE = Path(__file__).resolve().parent / "pipeline_stats.c"
RADV_ICDS = ("/usr/share/vulkan/icd.d/radeon_icd.x86_64.json",
             "/usr/share/vulkan/icd.d/radeon_icd.json")
#: RADV_FORCE_FAMILY names: RDNA2 (gfx1030), RDNA3 (gfx1100), GCN5 (gfx900).
FAMILIES = ("navi21", "gfx1100", "vega10")
#: The budget of issue-level targets for the default lookup and caustic pass, RDNA2 wave64.
VGPR_BUDGET = 64
#: The default caustic pass's (the cover gather's) budget, RDNA2 wave64: no scratch, no
#: spills and at most this many VGPRs.
COVER_VGPR_BUDGET = 48

GLSLANG = ("glslangValidator", "-V", "-R", "--amb", "--aml", "--target-env", "vulkan1.2")


class CompilerUnavailable(RuntimeError):
    """A piece of the toolchain (glslang, cc, Vulkan headers, RADV) is missing."""


def radv_icd() -> str:
    for path in RADV_ICDS:
        if Path(path).is_file():
            return path
    raise CompilerUnavailable("Mesa's RADV Vulkan driver is not installed (no radeon_icd*.json "
                              "in /usr/share/vulkan/icd.d); apt-get install mesa-vulkan-drivers")


def tool_path() -> Path:
    """The compiled pipeline_stats, built once per source text into a cache folder."""
    digest = hashlib.sha256(C_SOURCE.read_bytes()).hexdigest()[:12]
    cache = Path(os.environ.get("XDG_CACHE_HOME", Path.home() / ".cache")) / "blockhash"
    exe = cache / f"pipeline_stats-{digest}"
    if exe.is_file():
        return exe
    cc = shutil.which(os.environ.get("CC", "cc")) or shutil.which("gcc")
    if not cc:
        raise CompilerUnavailable("no C compiler (cc or gcc) to build pipeline_stats; "
                                  "apt-get install gcc")
    cache.mkdir(parents=True, exist_ok=True)
    tmp = exe.with_suffix(f".{os.getpid()}.tmp")
    run = subprocess.run([cc, "-O1", "-o", str(tmp), str(C_SOURCE), "-lvulkan"],
                         capture_output=True, text=True)
    if run.returncode:
        raise CompilerUnavailable(f"building {C_SOURCE.name} failed (the Vulkan headers and "
                                  f"loader come with apt-get install libvulkan-dev):\n{run.stderr}")
    tmp.replace(exe)
    return exe


def available() -> str | None:
    """None when the whole toolchain is here, else what is missing and how to get it."""
    try:
        if not shutil.which(GLSLANG[0]):
            raise CompilerUnavailable("glslangValidator is not on PATH; apt-get install glslang-tools")
        radv_icd()
        tool_path()
    except CompilerUnavailable as exc:
        return str(exc)
    return None


def _spirv(text: str, stage: str, folder: Path) -> Path:
    src, spv = folder / f"shader.{stage}", folder / f"{stage}.spv"
    src.write_text(text)
    run = subprocess.run([*GLSLANG, "-S", stage, "-o", str(spv), str(src)],
                         capture_output=True, text=True)
    if run.returncode:
        raise RuntimeError(f"glslang rejected the {stage} shader:\n{run.stdout}{run.stderr}")
    return spv


def compile_stats(fragment: str, family: str = "navi21", *, wave32: bool = False) -> dict:
    """ACO's statistics of ``fragment`` (GLSL 4.50 text) in a full-screen pipeline on
    RADV's null ``family``.  Keys: VGPRs, preVGPRs, SGPRs, spilledVGPRs, spilledSGPRs,
    scratch_wave (bytes per wave), scratch_lane (bytes per lane), waves_per_simd (RADV's
    "subgroups per SIMD", in wave32 equivalents on RDNA), instructions, code_bytes, wave."""
    from blockhash.gl.shaderlib import FULLSCREEN_VS

    env = dict(os.environ, RADV_FORCE_FAMILY=family, VK_ICD_FILENAMES=radv_icd(),
               MESA_SHADER_CACHE_DISABLE="true")
    env.pop("VK_DRIVER_FILES", None)
    if wave32:
        env["RADV_PERFTEST"] = "pswave32"
    with tempfile.TemporaryDirectory(prefix="bh-stats-") as tmp:
        folder = Path(tmp)
        vs, fs = _spirv(FULLSCREEN_VS, "vert", folder), _spirv(fragment, "frag", folder)
        run = subprocess.run([str(tool_path()), str(vs), str(fs)], capture_output=True,
                             text=True, env=env)
    if run.returncode:
        raise RuntimeError(f"pipeline_stats failed on {family}:\n{run.stderr}")
    raw = {}
    for line in run.stdout.splitlines():
        stage, name, value = line.split("\t")
        if stage == "fragment":
            raw[name] = value
    wave = int(raw["Subgroup size"])
    scratch = int(raw["Scratch size"])
    return {"family": family, "wave": wave, "VGPRs": int(raw["VGPRs"]),
            "preVGPRs": int(raw["Pre-Sched VGPRs"]), "SGPRs": int(raw["SGPRs"]),
            "spilledVGPRs": int(raw["Spilled VGPRs"]), "spilledSGPRs": int(raw["Spilled SGPRs"]),
            "scratch_wave": scratch, "scratch_lane": scratch // wave,
            "waves_per_simd": int(raw["Subgroups per SIMD"]),
            "instructions": int(raw["Instructions"]), "code_bytes": int(raw["Code size"])}


def over_budget(stats: dict, vgprs: int = VGPR_BUDGET) -> list[str]:
    """What in ``stats`` breaks the GPU budget: scratch memory, spills, or a register
    demand (ACO's pre-scheduling VGPRs) above ``vgprs``; [] when it fits."""
    broken = []
    if stats["scratch_lane"]:
        broken.append(f"{stats['scratch_lane']} B of scratch memory per lane")
    if stats["spilledVGPRs"] or stats["spilledSGPRs"]:
        broken.append(f"{stats['spilledVGPRs']} VGPRs and {stats['spilledSGPRs']} SGPRs spilled")
    if stats["preVGPRs"] > vgprs:
        broken.append(f"{stats['preVGPRs']} VGPRs demanded (budget {vgprs})")
    return broken


# --- the shaders blockhash runs ---------------------------------------------------------------

def sample_photons(n: int = 20_000, seed: int = 1) -> np.ndarray:
    """A caustic-like map: half in a thin cardioid band on a floor, half spread over it."""
    rng = np.random.default_rng(seed)
    t = rng.uniform(0, 2 * np.pi, n // 2)
    r = 0.25 * (1 - np.cos(t)) + rng.normal(0, 0.005, t.size)
    band = np.stack([r * np.cos(t), np.zeros_like(t), r * np.sin(t)], 1)
    floor = rng.uniform(-1, 1, (n - n // 2, 3))
    floor[:, 1] = 0
    return np.concatenate([band, floor]).astype(np.float32)


def _largest(record) -> str:
    return max(record, key=lambda c: len(c.text)).text


LOOKUPS = ("walk", "hash", "cells", "paper")


def lookup_shaders(k: int = 50, A: int = 8, *, lookups=LOOKUPS, kdtree: bool = True,
                   every_variant: bool = False, backend: str | None = None) -> dict[str, str]:
    """The lookup's fragment shaders, as ``GLLookup.query`` compiles them: each lookup
    (the walk, the tables hashed, the Hilbert cells, the paper preset) with its fetch-only
    floor (``lookups``, of :data:`LOOKUPS`), the exact kd-tree shader, and with
    ``every_variant`` each named shader variant of the walk and of the hashing."""
    from blockhash import BlockHashIndex
    from blockhash.gl import GLLookup
    from blockhash.gl.kdtree import GLKdTree
    from blockhash.gl.shaderlib import Variant, recording, variants

    P = sample_photons()
    q = P[:64]
    index = BlockHashIndex(P, k=k, A=A)
    walk = index
    hashed = copy.copy(index)
    hashed.params = replace(index.params, best_first=False, cells=False)
    cells = copy.copy(index)
    cells.params = replace(index.params, cells=True)
    out = {}
    for name, ix, variant in (("walk", walk, "default"), ("hash", hashed, "default"),
                              ("cells", cells, "default"), ("paper", None, "paper")):
        if name not in lookups:
            continue
        if ix is None:
            with warnings.catch_warnings():  # the paper's marginal layout orphans blocks
                warnings.simplefilter("ignore")
                ix = BlockHashIndex(P, k=k, A=A, preset="paper")
        lookup = GLLookup(ix, backend=backend)
        for fetch_only in (False, True):
            with recording() as got:
                lookup.query(q, k, A=A, variant=variant, fetch_only=fetch_only)
            out[f"lookup {name}{' fetch-only' if fetch_only else ''}"] = _largest(got)
        if every_variant and name in ("walk", "hash"):
            seen = {Variant.parse("default").name: out[f"lookup {name}"]}
            for v in variants():
                canonical = Variant.parse(v).name
                if canonical not in seen:  # GLLookup compiles each variant once
                    with recording() as got:
                        lookup.query(q, k, A=A, variant=v)
                    seen[canonical] = _largest(got)
                out[f"lookup {name} variant {v}"] = seen[canonical]
        lookup.release()
    if kdtree:
        with recording() as got:
            GLKdTree(P, backend=backend).query(q, k)
        out["kd-tree"] = _largest(got)
    return out


def caustic_shaders(scene: str, *, k: int = 50, A: int = 8, photons: int = 20_000,
                    lookups=("cover", "walk", "cells", "splat"),
                    backend: str | None = None) -> dict[str, str]:
    """The caustic pass's three stages (blockhash.frame.caustic.STAGES) on the scene's own
    pixels at 16 x 16, for each of ``lookups`` ('cover': the default render's cover gather,
    'walk', 'cells'), and 'splat': the photon-splatting peer's fragment stage (its per-photon
    vertex stage runs once a photon, not per pixel, and is not compiled here)."""
    from blockhash import BlockHashIndex
    from blockhash.frame.caustic import STAGES, CausticPass
    from blockhash.frame.gbuffer import rasterize
    from blockhash.frame.scene_rays import SceneRays
    from blockhash.frame.shading import shading_points
    from blockhash.gl.shaderlib import recording
    from blockhash.photons.tracing import trace_caustic_photons
    from blockhash.scene.loader import load_scene
    from blockhash.scene.materials import receiver_materials
    from blockhash.scene.model import MirrorMaterial

    sc = load_scene(scene)
    pm = trace_caustic_photons(sc, photons, seed=sc.photons.seed)
    index = BlockHashIndex(pm.positions, k=k, A=A, directions=pm.directions,
                           normals=pm.normals, powers=pm.powers)
    gbuf = rasterize(sc.camera, sc.objects, size=(16, 16), backend=backend)
    points = shading_points(sc.camera, gbuf, sc.objects, SceneRays(sc.objects), (MirrorMaterial,))
    cells = copy.copy(index)
    cells.params = replace(index.params, cells=True)
    out = {}
    for name, ix in (("cover", index), ("walk", index), ("cells", cells)):
        if name not in lookups:
            continue
        cp = CausticPass(ix, backend=backend, gather="cover" if name == "cover" else "knn")
        for stage in STAGES:
            with recording() as got:
                cp.time_stages(points, receiver_materials(sc.objects), k=k, A=A, repeat=1, warmup=0,
                               stages=(stage,))
            out[f"caustic {name}: {stage}"] = _largest(got)
    if "splat" in lookups:
        from blockhash.frame.cover_estimate import cover_gather
        from blockhash.studies.shaders.splat_pass import SplatPass

        with recording() as got:
            SplatPass(cover_gather(index, k), backend=backend).render(
                points, receiver_materials(sc.objects), sc.camera)
        out["caustic splat: fragment"] = _largest(got)
    return out


def gather(families=FAMILIES, *, scene=None, k=50, A=8, lookups=LOOKUPS, kdtree=True,
           every_variant=False, wave32=False, backend=None, progress=print) -> list[dict]:
    """One row per shader and family: its name, family and :func:`compile_stats`."""
    shaders = lookup_shaders(k, A, lookups=lookups, kdtree=kdtree, every_variant=every_variant,
                             backend=backend)
    if scene:
        shaders.update(caustic_shaders(scene, k=k, A=A, backend=backend))
    rows = []
    for name, text in shaders.items():
        for fam in families:
            rows.append({"shader": name, **compile_stats(text, fam, wave32=wave32)})
            progress(format_row(rows[-1]))
    return rows


COLUMNS = (("shader", "{:<44}"), ("family", "{:<8}"), ("wave", "{:>4}"), ("VGPRs", "{:>5}"),
           ("preVGPRs", "{:>8}"), ("spilledVGPRs", "{:>6}"), ("scratch_lane", "{:>12}"),
           ("waves_per_simd", "{:>5}"), ("instructions", "{:>6}"), ("code_bytes", "{:>6}"))
HEADER = ("shader", "family", "wave", "VGPRs", "preVGPR", "spillV", "scratch B/ln", "w/SIMD",
          "instrs", "code B")


def format_row(row: dict) -> str:
    return " ".join(fmt.format(row[key]) for key, fmt in COLUMNS)


def markdown(rows: list[dict]) -> str:
    """The BENCHMARKS.md table of ``rows``: RDNA2 in full, RDNA3's registers and spills and
    GCN5's occupancy beside it (a family not in the rows is left out)."""
    by: dict = {}
    for r in rows:
        by.setdefault(r["shader"], {})[r["family"]] = r
    out = ["| shader | VGPRs (ACO demand) | spilled | scratch B/lane | waves/SIMD (w32 eq.) "
           "| instructions | RDNA3: VGPRs, spilled | GCN5: waves/SIMD |",
           "| --- | --- | --- | --- | --- | --- | --- | --- |"]
    for name, f in by.items():
        a, b, c = f.get("navi21"), f.get("gfx1100"), f.get("vega10")
        if a is None:
            continue
        out.append(f"| {name} | {a['VGPRs']} ({a['preVGPRs']}) | {a['spilledVGPRs']} | "
                   f"{a['scratch_lane']:,} | {a['waves_per_simd']} | {a['instructions']:,} | "
                   + (f"{b['VGPRs']}, {b['spilledVGPRs']}" if b else "-") + " | "
                   + (f"{c['waves_per_simd']}" if c else "-") + " |")
    return "\n".join(out)


def variant_summary(rows: list[dict]) -> str:
    """The named shader variants' rows (``lookup L variant V``) summed up per lookup,
    selection and duplicate removal: ranges over the other choices (search, priority, cull)."""
    from blockhash.gl.shaderlib import Variant

    groups: dict = {}
    for r in rows:
        if " variant " in r["shader"] and r["family"] == "navi21":
            lookup, name = r["shader"].split(" variant ")
            v = Variant.parse(name)
            groups.setdefault((lookup.split()[1], v.select, v.dedup), []).append(r)
    out = ["| lookup | select | dedup | variants | VGPR demand | scratch B/lane | waves/SIMD "
           "| instructions |", "| --- | --- | --- | --- | --- | --- | --- | --- |"]
    for key in sorted(groups):
        rs = groups[key]

        def span(k):
            lo, hi = min(r[k] for r in rs), max(r[k] for r in rs)
            return f"{lo:,}" if lo == hi else f"{lo:,}-{hi:,}"
        scratch = ", ".join(f"{v:,}" for v in sorted({r["scratch_lane"] for r in rs}))
        out.append(f"| {key[0]} | {key[1]} | {key[2]} | {len(rs)} | {span('preVGPRs')} | "
                   f"{scratch} | {span('waves_per_simd')} | {span('instructions')} |")
    return "\n".join(out)
