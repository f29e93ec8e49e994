"""Render the reference images that tests/frame/test_reference_images.py compares against.

    python tools/regenerate_references.py

Run it after a change that is meant to alter the images, look at the new ones beside the
old (``blockhash compare NEW OLD --strip strip.png``), and commit them.  When the settings
change, measure the photon noise again and update the test's limits::

    blockhash tolerance scenes/ring.toml --seeds 6 --photons 20000 --size 48x48
"""

from __future__ import annotations

import argparse
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

from blockhash.cli import main

#: reference file -> blockhash render arguments (the test's SETTINGS).
REFERENCES = {
    "tests/data/ring-48x48.exr": ["scenes/ring.toml", "--size", "48x48", "--photons", "20000",
                                  "--seed", "1"],
}

if __name__ == "__main__":
    argparse.ArgumentParser(description=__doc__.splitlines()[0]).parse_args()
    for out, args in REFERENCES.items():
        main(["render", str(ROOT / args[0]), *args[1:], "-o", str(ROOT / out)])
        (ROOT / out).with_suffix(".png").unlink()
