"""A GPU compiler's view of the shaders blockhash runs: registers, scratch memory, occupancy.

Mesa's RADV Vulkan driver compiles pipelines on a null device, with no GPU
(``RADV_FORCE_FAMILY``).  This tool records the fragment shaders that the lookup
(``GLLookup.query``), the exact kd-tree shader and the caustic pass really hand the GL
driver (``blockhash.gl.shaderlib.recording``; llvmpipe compiles them as usual), turns
each into SPIR-V with glslang's relaxed GL rules (no text changed), and reads ACO's
statistics (:mod:`blockhash.studies.shaders.gpu_compiler`, which does the work).

    python tools/shader_stats.py                       # the named shaders, RDNA2/RDNA3/GCN
    python tools/shader_stats.py --family navi21 --variants   # plus every lookup variant
    python tools/shader_stats.py --json docs/shader-stats.json

Figures are static and per shader: they show what lands in scratch memory (local arrays
indexed by variables, spills) and the register demand that sets occupancy; they do not
time anything.  Needs glslangValidator, a C compiler, the Vulkan headers and loader and
Mesa's RADV ICD (Debian: glslang-tools gcc libvulkan-dev mesa-vulkan-drivers).
"""

from __future__ import annotations

import argparse
import json
import shlex
import sys
from pathlib import Path

from blockhash.studies.command import ToolParser, count, listing, write_json
from blockhash.studies.shaders.gpu_compiler import (
    COLUMNS,
    FAMILIES,
    HEADER,
    LOOKUPS,
    available,
    gather,
    markdown,
    variant_summary,
)


def lookup_name(text: str) -> str:
    if text not in LOOKUPS:
        raise argparse.ArgumentTypeError(f"{text!r}: expected one of {', '.join(LOOKUPS)}")
    return text


def main(argv=None) -> int:
    ap = ToolParser(__doc__, __file__)
    ap.add_argument("--family", type=listing(str), default=list(FAMILIES),
                    help=f"RADV_FORCE_FAMILY names, comma-separated (default {','.join(FAMILIES)})")
    ap.add_argument("--scene", type=lambda text: ap.scene(text) if text else None,
                    default="scenes/ring.toml", help="scene (a path or a name under scenes/) "
                    "whose caustic pass is compiled ('' for none; default scenes/ring.toml)")
    ap.add_argument("--k", type=count, default=50)
    ap.add_argument("--A", type=count, default=8)
    ap.add_argument("--lookups", type=listing(lookup_name), default=list(LOOKUPS),
                    help=f"the lookups compiled, each with its fetch-only floor (default "
                    f"{','.join(LOOKUPS)})")
    ap.add_argument("--no-kdtree", dest="kdtree", action="store_false",
                    help="leave out the exact kd-tree shader")
    ap.add_argument("--variants", action="store_true",
                    help="also every named shader variant of the walk and of the hashing")
    ap.add_argument("--wave32", action="store_true", help="RDNA fragment shaders in wave32")
    ap.add_argument("--backend", choices=("egl", "osmesa"), default=None)
    ap.json_output("write the rows to this JSON file")
    ap.add_argument("--table", metavar="JSON", type=Path, help="print the markdown table of a "
                    "JSON file this tool wrote, and nothing else")
    a = ap.parse_args(argv)
    if a.table:
        rows = json.loads(a.table.read_text())["rows"]
        print(variant_summary(rows) if any(" variant " in r["shader"] for r in rows)
              else markdown(rows))
        return 0
    missing = available()
    if missing:
        print(f"shader_stats: {missing}", file=sys.stderr)
        return 2
    print(" ".join(fmt.format(h) for h, (_, fmt) in zip(HEADER, COLUMNS)))
    rows = gather(a.family, scene=a.scene, k=a.k, A=a.A, lookups=a.lookups, kdtree=a.kdtree,
                  every_variant=a.variants, wave32=a.wave32, backend=a.backend)
    if a.json:
        command = shlex.join(["python", "tools/shader_stats.py", *(argv or sys.argv[1:])])
        write_json(a.json, {"command": command, "rows": rows})
    return 0


if __name__ == "__main__":
    sys.exit(main())
