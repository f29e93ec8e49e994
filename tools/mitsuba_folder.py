"""Published Mitsuba 3 scenes, rendered by blockhash and by Mitsuba from the same files, in a
table: which render and which are refused (with the refusal's reason), the warnings the import
gives, the flux ratio and the blurred relative RMS of blockhash's image against Mitsuba's
(:mod:`blockhash.studies.published`).

Every ``*.xml`` directly in each FOLDER (an included part in a subfolder is read through the
file that includes it), or the files given.  Needs the extra blockhash[mitsuba].

usage: python tools/mitsuba_folder.py FOLDER_OR_FILE... [--size 64] [--spp 1024]
                                      [--passes 8] [-D NAME=VALUE] [--peer-spp N] [--json FILE]
"""

import sys
from collections import Counter
from pathlib import Path

from blockhash.cli.args import define_option, defines
from blockhash.studies.command import ToolParser, count, write_json
from blockhash.studies.published import compare


def files(items) -> list[Path]:
    out = []
    for item in map(Path, items):
        out.extend(sorted(item.glob("*.xml")) if item.is_dir() else [item])
    return out


def reason(message: str) -> str:
    """The refusal without its file:line, shortened for a table cell."""
    text = message.split("\n")[0]
    text = text.split(": ", 1)[1] if ": " in text else text
    return text[:140].replace("|", "/")


def main(argv=None) -> int:
    p = ToolParser(__doc__, __file__)
    p.add_argument("paths", nargs="+", help="folders of Mitsuba XML files, or files")
    p.add_argument("--size", type=count, default=64, help="longer image side in pixels")
    p.add_argument("--spp", type=count, default=1024, help="Mitsuba's samples per pixel")
    p.add_argument("--passes", type=count, default=8, help="blockhash's passes")
    p.add_argument("--peer-spp", type=count, help="also render Mitsuba at this many samples "
                   "a pixel (another seed) and give its blurred error against the same "
                   "reference: what an unbiased render reaches at that count")
    p.add_argument("--json", help="write the rows to this file")
    define_option(p)
    args = p.parse_args(argv)
    rows, refusals = [], Counter()
    peer = f" Mitsuba at {args.peer_spp} spp, blurred |" if args.peer_spp else ""
    print("| file | renders | warnings | blockhash s | Mitsuba s | flux (r, g, b) | blurred rel. "
          f"RMS |{peer}")
    print("| --- | --- | --- | --- | --- | --- | --- |" + (" --- |" if peer else ""))
    for path in files(args.paths):
        row = compare(path, size=args.size, spp=args.spp, passes=args.passes,
                      defines=defines(args.define), peer_spp=args.peer_spp)
        rows.append(row)
        if row.refused:
            refusals[reason(row.refused)] += 1
            print(f"| {path.name} | no: {reason(row.refused)} | | | | | |", flush=True)
            continue
        if row.mitsuba_error:
            print(f"| {path.name} | yes | {len(row.warnings)} | {row.seconds:.1f} | Mitsuba "
                  f"failed: {reason(row.mitsuba_error)} | | |", flush=True)
            continue
        flux = ", ".join(f"{f:.3f}" for f in row.flux)
        extra = f" {row.peer_blurred:.3f} |" if peer else ""
        print(f"| {path.name} | yes | {len(row.warnings)} | {row.seconds:.1f} | "
              f"{row.mitsuba_seconds:.1f} | {flux} | {row.blurred:.3f} |{extra}", flush=True)
    done = sum(r.refused is None for r in rows)
    print(f"\n{done} of {len(rows)} render.  Refusals by reason:")
    for text, n in refusals.most_common():
        print(f"- {n}: {text}")
    if args.json:
        write_json(args.json, [r.as_dict() for r in rows])
    return 0


if __name__ == "__main__":
    sys.exit(main())
