"""Render the reference images that tests/frame/test_reference_images.py compares against.

    python tools/regenerate_references.py
    python tools/regenerate_references.py ring-48x48 --out /tmp/references   # one, elsewhere

Each reference is the render the test makes (``render_scene``: one pass, every photon
gathered, the scene's samples per pixel) at the test's settings.  Run it after a change that
is meant to alter the images, look at the new ones beside the old (``blockhash compare NEW
OLD --strip strip.png``), and commit them.  When the settings change, measure the photon
noise again and update the test's limits::

    blockhash tolerance scenes/ring.toml --seeds 6 --photons 20000 --size 48x48
"""

from __future__ import annotations

from pathlib import Path

from blockhash.evaluate.images import write_exr
from blockhash.passes.pipeline import render_scene
from blockhash.scene.loader import load_scene
from blockhash.studies.command import ToolParser

ROOT = Path(__file__).resolve().parents[1]

#: reference name (its file is NAME.exr in tests/data/) -> scene and render_scene settings
#: (the test's SETTINGS).
REFERENCES = {
    "ring-48x48": ("scenes/ring.toml", dict(photons=20_000, size=(48, 48), seed=1)),
}


def main(argv=None) -> None:
    parser = ToolParser(__doc__, __file__)
    parser.add_argument("names", nargs="*", metavar="NAME",
                        help=f"the references to render (default all: {', '.join(REFERENCES)})")
    parser.add_argument("--out", type=Path, default=ROOT / "tests" / "data",
                        help="folder to write NAME.exr in (default: the checkout's tests/data)")
    args = parser.parse_args(argv)
    unknown = [name for name in args.names if name not in REFERENCES]
    if unknown:
        parser.error(f"no reference named {', '.join(unknown)}; the references are "
                     f"{', '.join(REFERENCES)}")
    for name in args.names or REFERENCES:
        scene, settings = REFERENCES[name]
        result = render_scene(load_scene(parser.scene(scene)), **settings)
        out = args.out / f"{name}.exr"
        out.parent.mkdir(parents=True, exist_ok=True)
        write_exr(out, result.layers(), {"blockhash:spp": result.spp})
        print(f"wrote {out}")


if __name__ == "__main__":
    main()
