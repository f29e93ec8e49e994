"""What a GPU machine's run carries beside the checkout, packed under the 64 MiB carry limit.

The checkout travels to a lent GPU machine with at most 64 MiB in all: its tracked files, and
the ignored folders a run names.  The run needs ``.gl/`` (the GL dispatch libraries the GPU
image lacks) and ``.whl/`` (the project's wheel, the wheels the image lacks, Mitsuba's RGB
variants and drjit's wheel, and ``run.sh``, which installs them there), prepared on a machine
with the package registries: with the tracked files about 74 MB as zips, over the limit.
Wheels are deflated zips; stored uncompressed and packed together with xz they take about
half (the shared libraries compress far better in one xz stream), so this tool writes
``.carry/whl.tar.xz`` from ``.whl/`` and says what the run carries:

    python tools/gpu_carry.py [--preset 6]

and on the GPU machine (the device tool's ``carry`` naming ``.gl`` and ``.carry``):

    python3 -c "import tarfile; tarfile.open('.carry/whl.tar.xz').extractall('.')" \\
        && OUT=$OUT STEPS=photons,frames bash tools/gpu_bench.sh

The archive unpacks to ``.whl/`` (stored zips are valid wheels, pip installs them).  The tool
fails, naming the sizes, when the tracked files and the carry pass the limit.
"""

import io
import subprocess
import sys
import tarfile
import zipfile
from pathlib import Path

from blockhash.studies.command import ToolParser

ROOT = Path(__file__).resolve().parents[1]
#: The device tool's limit on the working tree and its carried folders together.
LIMIT = 64 * 2**20


def stored(wheel: Path) -> bytes:
    """``wheel``'s zip again with every member stored uncompressed (a valid wheel still)."""
    out = io.BytesIO()
    with zipfile.ZipFile(wheel) as src, zipfile.ZipFile(out, "w", zipfile.ZIP_STORED) as dst:
        for info in src.infolist():
            dst.writestr(info, src.read(info.filename), compress_type=zipfile.ZIP_STORED)
    return out.getvalue()


def pack(folder: Path, archive: Path, preset: int = 6) -> int:
    """Packs ``folder`` (its wheels stored, its other files as they are) into ``archive``, an
    xz tar whose members unpack to ``.whl/``; returns the archive's bytes."""
    archive.parent.mkdir(parents=True, exist_ok=True)
    with tarfile.open(archive, "w:xz", preset=preset) as tar:
        for path in sorted(folder.iterdir()):
            data = stored(path) if path.suffix == ".whl" else path.read_bytes()
            info = tarfile.TarInfo(f".whl/{path.name}")
            info.size, info.mode = len(data), path.stat().st_mode & 0o777
            tar.addfile(info, io.BytesIO(data))
    return archive.stat().st_size


def tracked_bytes(root: Path) -> int:
    """Bytes of the checkout's tracked files (what travels whatever a run carries)."""
    names = subprocess.run(["git", "ls-files", "-z"], cwd=root, capture_output=True,
                           check=True).stdout.split(b"\0")
    return sum((root / n.decode()).stat().st_size for n in names if n and (root / n.decode()).is_file())


def folder_bytes(folder: Path) -> int:
    return sum(p.stat().st_size for p in folder.rglob("*") if p.is_file())


def main(argv=None):
    p = ToolParser(__doc__, __file__)
    p.add_argument("--root", type=Path, default=ROOT, help="the checkout (default this one)")
    p.add_argument("--preset", type=int, default=6, choices=range(10), metavar="0-9",
                   help="xz preset (default 6)")
    args = p.parse_args(argv)
    root = args.root.resolve()
    whl = root / ".whl"
    if not (whl / "run.sh").is_file():
        raise SystemExit(f"{whl} has no run.sh: prepare the GPU run's wheels and run.sh in .whl/ "
                         "first, on a machine with the package registries")
    archive = root / ".carry" / "whl.tar.xz"
    size = pack(whl, archive, args.preset)
    gl = folder_bytes(root / ".gl") if (root / ".gl").is_dir() else 0
    tracked = tracked_bytes(root)
    total = tracked + size + gl
    mib = 2.0**20
    print(f"wheels {folder_bytes(whl) / mib:.1f} MiB as zips -> {archive.relative_to(root)} "
          f"{size / mib:.1f} MiB; .gl {gl / mib:.1f} MiB; tracked files {tracked / mib:.1f} MiB; "
          f"carried in all {total / mib:.1f} MiB of {LIMIT / mib:.0f}")
    if total > LIMIT:
        raise SystemExit(f"the carry is {total / mib:.1f} MiB, past the {LIMIT / mib:.0f} MiB "
                         "limit: drop wheels the run does not need from .whl/ and pack again")
    print("carry: .gl, .carry (unpack .carry/whl.tar.xz to .whl/ on the GPU machine first)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
