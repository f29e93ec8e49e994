"""Smooth conductors (a MirrorMaterial with eta and k): a photon reflected off gold carries
the exact Fresnel reflectance of gold's complex index at its angle, on the host tracer (the
oracle) and on the Dr.Jit kernels alike; the function itself is Mitsuba's."""

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from blockhash.errors import InputError
from blockhash.photons.tracing import PhotonSource
from blockhash.scene.loader import load_scene
from blockhash.scene.materials import MirrorMaterial
from blockhash.scene.mitsuba.spectra import conductor_preset
from blockhash.scene.optics import conductor_fresnel

GOLD = Path(__file__).resolve().parents[1] / "reference" / "mitsuba_xml" / "gold.xml"


def devices():
    from blockhash.device.choice import resolve

    out = ["host"]
    try:
        resolve("cpu")
        out.append("cpu")
    except InputError:
        pass
    return out


def perfect(scene):
    """``scene`` with its conductor a perfect mirror of the same reflectance."""
    objects = tuple(replace(o, material=MirrorMaterial(o.material.reflectance))
                    if getattr(o.material, "is_conductor", False) else o for o in scene.objects)
    return replace(scene, objects=objects)


@pytest.mark.parametrize("device", devices())
def test_each_photon_off_gold_carries_golds_fresnel_reflectance_at_its_angle(device):
    scene = load_scene(GOLD)
    mirror = next(o for o in scene.objects if o.is_specular)
    assert mirror.material.is_conductor
    n = np.asarray(mirror.mesh.face_normals[0], dtype=np.float64)  # a flat rectangle
    gold = PhotonSource(scene, device=device).emit(20_000, seed=5)
    plain = PhotonSource(perfect(scene), device=device).emit(20_000, seed=5)
    assert len(gold) == len(plain) > 1000  # the same paths: only the weights differ
    np.testing.assert_allclose(gold.positions, plain.positions, atol=1e-5)
    # one flat mirror, the only specular object: every stored photon reflected once, off it
    cos = np.abs(plain.directions.astype(np.float64) @ n)
    expected = conductor_fresnel(cos[:, None], mirror.material.eta, mirror.material.k)
    ratio = gold.powers.astype(np.float64) / plain.powers
    np.testing.assert_allclose(ratio, expected, rtol=2e-5 if device == "host" else 2e-4)
    assert ratio[:, 2].mean() < 0.5 < ratio[:, 0].mean()  # gold: red kept, blue lost


def test_the_conductor_fresnel_is_mitsubas():
    from conftest import mitsuba_or_skip

    mitsuba_or_skip()
    from blockhash.reference.mitsuba import load_mitsuba_module

    mi, _ = load_mitsuba_module()
    for name in ("Au", "Cu", "Ag", "AlSb", "none"):
        eta, k = conductor_preset(name) or (np.zeros(3), np.ones(3))
        for c in (1.0, 0.8, 0.41, 0.1, 0.01, 0.0):
            ours = conductor_fresnel(c, eta, k)
            theirs = [float(np.ravel(mi.fresnel_conductor(c, mi.Complex2f(float(e), float(q))))[0])
                      for e, q in zip(eta, k)]
            np.testing.assert_allclose(ours, np.nan_to_num(theirs, nan=1.0), atol=2e-6,
                                       err_msg=f"{name} at cos {c}")
    assert np.all(conductor_fresnel(1.0, [0.0] * 3, [0.0] * 3) == 1.0)  # Mitsuba: 0 / 0


def test_a_conductor_needs_both_eta_and_k(tmp_path):
    with pytest.raises(InputError, match=r"MirrorMaterial\.k.*both eta and k"):
        MirrorMaterial(1.0, eta=[0.2, 0.4, 1.4])
    with pytest.raises(InputError, match=r"MirrorMaterial\.eta\[1\].*\[0, 100\]"):
        MirrorMaterial(1.0, eta=[0.2, -1.0, 1.4], k=1.0)


def test_a_conductor_is_exported_to_mitsuba_and_read_back(tmp_path):
    from blockhash.scene.mitsuba.exporter import export_mitsuba

    scene = load_scene(GOLD)
    xml = export_mitsuba(scene, tmp_path / "out")
    back = next(o for o in load_scene(xml).objects if o.is_specular).material
    gold = next(o for o in scene.objects if o.is_specular).material
    assert back.is_conductor
    for name in ("reflectance", "eta", "k"):
        np.testing.assert_allclose(getattr(back, name), getattr(gold, name), rtol=1e-6)
