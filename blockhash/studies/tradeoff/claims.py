"""The paper's section-6 claims, checked against a trade study, and ``report.md``.

Each check reads only ``tradeoff.json``'s rows at the largest N with the base k and
the default preset and variant, and returns (what was measured, verdict):

1. "A between 8 and 10 is a good compromise": the knee is the smallest A whose error
   against the reference is within 10% of the best A's; agrees when 4 < knee <= 16.
2. "approximate images are darker": the flux ratio against exact kNN rises with A and
   stays below 1 at small A.
3. "query time is about linear in A": the slope of log(time) on log(A) over the A
   values whose queries examine at least ``CAP_BINDS`` of their cap A k (above them the
   cap no longer binds: the walk stops once the next box lies beyond the k-th neighbour,
   hashing once its buckets hold no more); agrees when it lies in [0.6, 1.4].
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

#: Relative margin that defines the knee of error against A (claim 1).
KNEE_MARGIN = 0.10
#: Share of the cap A k a query examines on average for the cap to count as binding (claim 3).
CAP_BINDS = 0.9


def _base_rows(study):
    plan = study["plan"]
    top = max(plan["photons"])
    rows = [r for r in study["rows"] if r["method"] == "bh" and r["photons"] == top
            and r["k"] == plan["k0"] and r["preset"] == "default" and r["variant"] == "default"]
    return sorted(rows, key=lambda r: r["A"])


def _time(row):
    s = row["seconds"]
    return s.get("gl_draw") or s["caustic_pass"]


def knee(study, key="rel_rms_reference_blur"):
    rows = _base_rows(study)
    if len(rows) < 3:
        return None, "too few A values"
    best = min(r[key] for r in rows)
    k = next(r["A"] for r in rows if r[key] <= best * (1 + KNEE_MARGIN))
    text = (f"error against the reference reaches within {KNEE_MARGIN:.0%} of its best at A = {k} "
            f"(errors: " + ", ".join(f"A={r['A']}: {r[key]:.3f}" for r in rows) + ")")
    return k, text


def check_claims(study) -> list[tuple[str, str, str]]:
    """[(claim, measured, verdict)] for the three claims of the module docstring."""
    rows = _base_rows(study)
    out = []
    k, text = knee(study)
    out.append(("A of 8 to 10 is a good compromise between speed and accuracy", text,
                "n/a" if k is None else ("agrees" if 4 < k <= 16 else "disagrees")))
    if len(rows) >= 2:
        flux = [(r["A"], r["flux_ratio_exact"]) for r in rows]
        darker = flux[0][1] < 1.0 and flux[0][1] < flux[-1][1]
        out.append(("approximate images (small A) are darker",
                    "flux ratio BH / exact kNN: " + ", ".join(f"A={a}: {f:.3f}" for a, f in flux),
                    "agrees" if darker else "disagrees"))
        binding = [r for r in rows if r["candidates"] >= CAP_BINDS * r["A"] * r["k"]]
        a_cap = binding[-1]["A"] if binding else None
        cand = ", ".join(f"A={r['A']}: {r['candidates']:.0f}" for r in rows)
        times = ", ".join(f"A={r['A']}: {_time(r) * 1e3:.1f} ms" for r in rows)
        pts = [(r["A"], _time(r)) for r in binding if _time(r) > 0]
        if len(pts) >= 2:
            slope = float(np.polyfit(np.log([p[0] for p in pts]), np.log([p[1] for p in pts]), 1)[0])
            above = (f"; above it the queries stop before the cap" if a_cap < rows[-1]["A"] else "")
            out.append(("query time is about linear in A",
                        f"candidates per query {cand}: at least {CAP_BINDS:.0%} of the cap A k "
                        f"up to A = {a_cap}{above}; pass times {times}; log-log slope of time on "
                        f"A up to A = {a_cap}: {slope:.2f}",
                        (f"agrees up to A = {a_cap}" if 0.6 <= slope <= 1.4 else "disagrees")
                        + (", flat above" if a_cap < rows[-1]["A"] else "")))
        else:
            out.append(("query time is about linear in A",
                        f"candidates per query {cand}: the cap A k binds at "
                        + (f"A = {a_cap} only" if binding else "no A") + f"; pass times {times}",
                        "n/a: the cap does not bind over two A values"))
    return out


def _fmt(x, spec=".3f"):
    return "-" if x is None or (isinstance(x, float) and math.isnan(x)) else format(x, spec)


def report_markdown(study: dict, plots: list[str]) -> str:
    plan, ref, m = study["plan"], study["reference"], study["machine"]
    name = Path(study["scene"]).name
    lines = [f"# Trade study: {name}", "",
             f"Scene `{study['scene']}` (content sha256 `{study['scene_digest'][:16]}`), "
             f"{study['size'][0]} x {study['size'][1]} pixels (caustic layers rendered at "
             f"{plan['supersample']}x and box-filtered), engine `{plan['engine']}`, photon seed "
             f"{study['seed']}. Every figure and number below comes from `tradeoff.json` in "
             "this directory, written by the command at the end.", "",
             f"Machine: {m.get('processor')} ({m.get('cpus')} CPUs), {m.get('gl_renderer', '?')}; "
             f"Python {m['python']}, numpy {m['numpy']}, scipy {m['scipy']}, moderngl "
             f"{m['moderngl']}, blockhash {m['blockhash']}.", "",
             "## Reference", "",
             f"Light tracing (`blockhash.reference.lighttrace`) with {ref['photons']:,} photons: the "
             "caustic seen directly, without density estimation; compared on "
             f"{ref['pixels_compared']:,} pixels (receivers seen directly, not next to a mirror "
             f"or the background). Its own noise: relative standard error {ref['rel_noise']:.3f} "
             "(RMS over those pixels, before blurring).", "",
             "Errors: `rel_rms_*` is RMS(image - truth) / RMS(truth); `*_blur` after a 2-pixel "
             "Gaussian blur of both (removes most per-pixel noise, keeps bias and blur); "
             "`flux_ratio_*` is the ratio of the sums (mean bias, < 1 darker).", "",
             "## The paper's claims (section 6)", "", "| claim | measured | verdict |",
             "|---|---|---|"]
    for claim, measured, verdict in check_claims(study):
        lines.append(f"| {claim} | {measured} | {verdict} |")
    lines += ["", "## Darkening per A (largest N, base k)", "",
              "| A | flux / exact kNN | flux / reference | rel RMS vs exact | rel RMS vs reference "
              "(blur) | false negatives | max dilation |", "|---|---|---|---|---|---|---|"]
    for r in _base_rows(study):
        lines.append(f"| {r['A']} | {_fmt(r['flux_ratio_exact'])} | "
                     f"{_fmt(r['flux_ratio_reference'])} | {_fmt(r['rel_rms_exact'])} | "
                     f"{_fmt(r['rel_rms_reference_blur'])} | {r['false_negatives']:.1%} | "
                     f"{_fmt(r['max_dilation'])} |")
    cover = [r for r in study["rows"] if r["method"] == "cover"]
    if cover:
        bh = {(r["photons"], r["k"]): r for r in study["rows"] if r["method"] == "bh"
              and r["A"] == study["plan"]["A0"] and r["preset"] == "default"
              and r["variant"] == "default"}
        lines += ["", "## The cover gather (the default render's gather) against the reference", "",
                  "Every photon whose own disc covers the point, so no A; its knobs are N, k (the "
                  "disc's photon count j = round(k - 2 sqrt(k))) and the samples per pixel. "
                  "'walk s' is the k-nearest walk's pass at the same N and k at the base A.", "",
                  "| N | k | spp | flux / reference | rel RMS (blur) | seconds | walk s |",
                  "|---|---|---|---|---|---|---|"]
        for r in sorted(cover, key=lambda r: (r["k"], r["photons"], r["spp"])):
            w = bh.get((r["photons"], r["k"]))
            walk = f"{w['seconds']['caustic_pass']:.3f}" if w else "-"
            lines.append(f"| {r['photons']:,} | {r['k']} | {r['spp']} | "
                         f"{_fmt(r['flux_ratio_reference'])} | {_fmt(r['rel_rms_reference_blur'])} | "
                         f"{r['seconds']['caustic_pass']:.3f} | {walk} |")
    ex = [r for r in study["rows"] if r["method"].startswith("exact")]
    if ex:
        lines += ["", "## Exact kNN against the reference", "",
                  "Exact rows' seconds are the whole exact caustic: the k-nearest search (cKDTree "
                  "on the CPU, or the kd-tree shader) plus the density estimate in numpy, where BH "
                  "rows run the estimate in the shader; they are upper bounds for an exact pass. "
                  "`blockhash bench` times the searches alone.", "",
                  "| method | N | k | flux / reference | rel RMS (blur) | seconds |", "|---|---|---|---|---|---|"]
        for r in sorted(ex, key=lambda r: (r["method"], r["k"], r["photons"])):
            lines.append(f"| {r['method']} | {r['photons']:,} | {r['k']} | "
                         f"{_fmt(r['flux_ratio_reference'])} | {_fmt(r['rel_rms_reference_blur'])} | "
                         f"{r['seconds']['caustic_pass']:.3f} |")
    lines += ["", "## Figures", ""]
    captions = {"accuracy_vs_A.png": "False negatives, dilations, error against exact kNN and "
                "time ratio per A (paper Figs. 12 and 14).",
                "pareto.png": "Error against the reference vs caustic pass time, every setting; "
                "the red line is the Pareto front; open markers are exact kNN.",
                "error_vs_N.png": "Error against the reference vs photons, per k: noise falls "
                "with N, blur grows with k.",
                "strip.png": "Caustic layer at A = 1, 2, 4, 8, 16, exact kNN and the reference "
                "(largest N, one exposure; paper Figs. 11 and 13). The reference leaves out caustics "
                "seen in mirrors: mirror pixels are black there."}
    for p in plots:
        lines += [f"![{p}]({p})", "", captions.get(p, ""), ""]
    if study.get("notes"):
        lines += ["## Notes", ""] + [f"- {n}" for n in study["notes"]] + [""]
    lines += ["## Regenerate", "", "```", study.get("command", "blockhash tradeoff SCENE -o DIR"),
              "```", ""]
    return "\n".join(lines)
