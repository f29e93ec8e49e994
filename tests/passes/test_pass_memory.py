"""What a render holds does not grow with its passes, and a traced map keeps its photons in
the compact dtypes (52 bytes a stored photon): numpy's allocations counted exactly under
tracemalloc after 20 passes against after 2."""

import gc
import platform
import tracemalloc
from pathlib import Path

import numpy as np
import pytest

import blockhash
from blockhash.passes.executors import InProcess
from blockhash.passes.heap import return_large_blocks
from blockhash.passes.plan import RenderPlan
from blockhash.passes.renderer import Renderer
from blockhash.passes.run import run_passes
from blockhash.photons.tracing import PhotonSource

pytestmark = pytest.mark.gl

SCENES = Path(__file__).resolve().parents[2] / "scenes"
PHOTONS = 6000


def numpy_bytes_after(scene, passes: int, overlap: bool) -> int:
    """Bytes of numpy arrays alive once a render of ``passes`` passes has returned, less the
    last pass's index and radii (the result carries them; their size varies pass to pass)."""
    renderer = Renderer(scene, photons=PHOTONS)
    gc.collect()
    tracemalloc.start()
    try:
        run_passes(renderer, RenderPlan(passes=passes, executor=InProcess(overlap=overlap)))
        renderer.index = renderer.radii = None
        gc.collect()
        snapshot = tracemalloc.take_snapshot()
    finally:
        tracemalloc.stop()
    arrays = snapshot.filter_traces([tracemalloc.DomainFilter(True, np.lib.tracemalloc_domain)])
    return sum(stat.size for stat in arrays.statistics("filename"))


@pytest.mark.parametrize("name,overlap", [("ring", True), ("ring", False), ("corner", True)])
def test_a_render_holds_no_array_of_a_finished_pass(name, overlap):
    scene = blockhash.load_scene(SCENES / f"{name}.toml").with_size(32, 32)
    numpy_bytes_after(scene, 1, overlap)  # compiled and cached before counting
    two = numpy_bytes_after(scene, 2, overlap)
    twenty = numpy_bytes_after(scene, 20, overlap)
    # One float32 a photon of a single pass kept each pass would add 18 x 24 KB; the
    # film, the last pass's index and the caches are the same after 2 passes and after 20.
    assert twenty - two < 4 * PHOTONS, (
        f"{name}: numpy holds {twenty - two:,} bytes more after 20 passes than after 2 "
        f"({two:,} -> {twenty:,}): a pass's array is kept past its pass")


def test_a_traced_map_keeps_52_bytes_a_photon():
    scene = blockhash.load_scene(SCENES / "ring.toml")
    photons = PhotonSource(scene).until_stored(5000, seed=3)
    held = sum(a.nbytes for a in (photons.positions, photons.directions, photons.normals,
                                  photons.powers, photons.objects))
    assert held == 52 * len(photons)
    assert photons.positions.dtype == np.float32 and photons.objects.dtype == np.int32


def test_the_heap_setting_is_made_once_and_leaves_a_callers_choice(monkeypatch):
    import blockhash.passes.heap as heap

    monkeypatch.setattr(heap, "_done", False)
    monkeypatch.setenv("MALLOC_MMAP_THRESHOLD_", "65536")
    assert heap.return_large_blocks() is False  # the environment's threshold stands
    monkeypatch.delenv("MALLOC_MMAP_THRESHOLD_")
    glibc = platform.libc_ver()[0] == "glibc"
    assert heap.return_large_blocks() is glibc  # set where glibc's mallopt is there
    assert return_large_blocks() is glibc  # and once: the second call finds it done
