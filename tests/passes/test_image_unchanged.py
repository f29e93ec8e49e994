"""A pass's photons in float32, the compiled tracer and the chunked stages change the image by
rounding only: the ring and the glass ball at a fixed seed against the images commit df31412
rendered (float64 photons, numpy's tracer), stored in tests/data/passes-df31412-48x48.npz, on
the host's tracer (device 'host', whose streams df31412 had); on the Dr.Jit kernels, whose
photons come from other streams, the image is df31412's within the noise of another seed.

Made with this file's own render, run by that commit::

    git worktree add /tmp/blockhash-df31412 df31412
    cd /tmp && PYTHONPATH=/tmp/blockhash-df31412 python /path/to/tests/passes/test_image_unchanged.py OUT.npz
"""

import sys
from pathlib import Path

import numpy as np
import pytest

import blockhash
from blockhash.passes.run import run_passes

ROOT = Path(__file__).resolve().parents[2]
REFERENCE = ROOT / "tests" / "data" / "passes-df31412-48x48.npz"
SCENES = ("ring", "glass")


def render(name: str, device: str = "host", seed: int = 7):
    """(caustic, direct, photons stored) of 2 passes of 20,000 photons at 48 x 48."""
    scene = blockhash.load_scene(ROOT / "scenes" / f"{name}.toml").with_size(48, 48)
    kwargs = {"device": device} if "device" in blockhash.RenderPlan.__dataclass_fields__ else {}
    r = blockhash.Renderer(scene, photons=20000, seed=seed, **kwargs)
    run_passes(r, blockhash.RenderPlan(passes=2))
    return r.image.caustic.astype(np.float32), r.image.direct.astype(np.float32), r.stored


@pytest.mark.gl
@pytest.mark.parametrize("name", SCENES)
def test_the_image_is_df31412s_but_for_rounding(name):
    ref = np.load(REFERENCE)
    caustic, direct, stored = render(name)
    assert stored == int(ref[f"{name}_stored"])  # the same photons stored
    np.testing.assert_allclose(direct, ref[f"{name}_direct"], rtol=1e-6, atol=1e-9)
    want = ref[f"{name}_caustic"]
    # 20,000 photons a pass carry a relative noise of several percent a pixel: rounding moves
    # the image by a hundredth of that (measured: ring 6e-4, glass 3e-8)
    rel = np.sqrt(np.mean((caustic - want) ** 2) / np.mean(want ** 2))
    assert rel < 2e-3, f"{name}: the caustic moved by {rel:.2e} (relative RMS) from df31412's"
    assert abs(caustic.sum() / want.sum() - 1) < 1e-4


def _rel(a, b):
    return float(np.sqrt(np.mean((a - b) ** 2) / np.mean(b ** 2)))


@pytest.mark.gl
@pytest.mark.parametrize("name", SCENES)
def test_the_kernels_image_is_df31412s_within_the_noise_of_another_seed(name):
    from blockhash.device.choice import resolve
    from blockhash.errors import InputError

    try:
        resolve("cpu")
    except InputError as exc:
        pytest.skip(f"no Dr.Jit CPU device here: {exc}")
    ref = np.load(REFERENCE)
    want = ref[f"{name}_caustic"]
    caustic, direct, stored = render(name, device="cpu")
    np.testing.assert_allclose(direct, ref[f"{name}_direct"], rtol=1e-6, atol=1e-9)
    other_seed = render(name, device="host", seed=8)[0]  # the noise between two streams
    noise = _rel(other_seed, want)
    assert _rel(caustic, want) < 1.5 * noise, (name, _rel(caustic, want), noise)
    assert abs(caustic.sum() / want.sum() - 1) < 3 * abs(other_seed.sum() / want.sum() - 1) + 0.01


if __name__ == "__main__":
    out = {}
    for name in SCENES:
        out[f"{name}_caustic"], out[f"{name}_direct"], stored = render(name)
        out[f"{name}_stored"] = np.array(stored)
    np.savez_compressed(sys.argv[1], **out)
