"""Write glsl/bh_merge_net.glsl: the fixed compare-exchange networks of select=merge
(:mod:`blockhash.gl.merge_network` says what each network is and generates the text).

The networks are constants of the algorithm, so they are generated once and committed (rerun
this after changing them; tests/gl/test_shaderlib.py checks the file is current and that every
network sorts).

    python tools/gen_merge_network.py            # rewrite the checkout's glsl/bh_merge_net.glsl
    python tools/gen_merge_network.py --check    # exit 1 if it is not current
"""

from __future__ import annotations

import sys
from pathlib import Path

from blockhash.gl.merge_network import check, render
from blockhash.studies.command import ToolParser

OUT = Path(__file__).resolve().parents[1] / "glsl" / "bh_merge_net.glsl"


def main(argv=None) -> int:
    parser = ToolParser(__doc__, __file__)
    parser.add_argument("--check", action="store_true",
                        help="write nothing; exit 1 if the file is not current")
    parser.add_argument("--out", type=Path, default=OUT,
                        help="the file to write or check (default: the checkout's "
                             "glsl/bh_merge_net.glsl)")
    args = parser.parse_args(argv)
    check()
    text = render()
    if args.check:
        current = args.out.is_file() and args.out.read_text() == text
        print(f"{args.out} is {'current' if current else 'not current: rerun without --check'}")
        return 0 if current else 1
    args.out.write_text(text)
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
