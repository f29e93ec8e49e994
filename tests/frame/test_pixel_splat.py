"""The pixel splat (blockhash/frame/pixel_splat.py): which photons it takes from the gather and
what each adds to its pixel, on hand-placed photons under the analytic plane's ceiling."""

import numpy as np
import pytest
from plane_scene import KD, H

from blockhash.frame.pixel_splat import splat_subpixel
from blockhash.frame.scene_rays import SceneRays
from blockhash.photons.paths import CausticPhotons
from blockhash.scene.camera import Pinhole
from blockhash.scene.materials import receiver_materials

CEILING = 1  # the plane scene's object order: mirror, ceiling


def _photons(xz, power=(1.0, 2.0, 3.0), normal=(0.0, -1.0, 0.0)):
    """Photons on the ceiling at the (x, z) points, arriving straight up."""
    xz = np.atleast_2d(np.asarray(xz, float))
    n = len(xz)
    pos = np.column_stack([xz[:, 0], np.full(n, H), xz[:, 1]])
    return CausticPhotons(positions=pos, directions=np.tile([0.0, 1.0, 0.0], (n, 1)),
                          normals=np.tile(normal, (n, 1)), powers=np.tile(power, (n, 1)),
                          emitted=n, stats={}, objects=np.full(n, CEILING))


@pytest.fixture(scope="module")
def view(plane):
    return Pinhole.of(plane.camera), SceneRays(plane.objects), receiver_materials(plane.objects)


def test_a_small_photon_the_camera_sees_adds_its_flux_over_the_pixel_to_its_pixel(view):
    pin, rays, materials = view
    photons = _photons([[0.05, -0.1]])
    image, keep = splat_subpixel(photons, np.array([1e-8]), pin, rays, materials, footprint=1.0)
    assert not keep[0]
    pix, cos_c = pin.project(photons.positions)
    d2 = float(np.sum((pin.eye - photons.positions[0]) ** 2))
    cos_x = (pin.eye - photons.positions[0])[1] * -1 / np.sqrt(d2)  # the normal is -y
    expected = np.array([1.0, 2.0, 3.0]) * KD / np.pi * cos_x / (pin.pixel_area * cos_c[0] ** 3 * d2)
    flat = image.reshape(-1, 3)
    np.testing.assert_allclose(flat[pix[0]], expected, rtol=1e-9)
    assert np.count_nonzero(flat.sum(1)) == 1  # nothing anywhere else


def test_the_footprint_bounds_the_disc_and_zero_splats_nothing(view, gl_mode):
    pin, rays, materials = view
    photons = _photons([[0.0, 0.0]])
    d = float(np.linalg.norm(pin.eye - photons.positions[0]))
    pixel_angle = 2.0 * pin.tan_y / pin.height
    edge = (0.5 * 2.0 * pixel_angle * d) ** 2  # r^2 where 2 r = footprint (2) * d * pixel angle
    _, under = splat_subpixel(photons, np.array([edge * 0.99]), pin, rays, materials, footprint=2.0)
    _, over = splat_subpixel(photons, np.array([edge * 1.01]), pin, rays, materials, footprint=2.0)
    image, off = splat_subpixel(photons, np.array([1e-12]), pin, rays, materials, footprint=0.0)
    assert not under[0] and over[0] and off[0] and not image.any()


def test_photons_the_camera_cannot_see_stay_in_the_gather(view):
    """Outside the image, on the face turned away from the camera: the gather keeps them, and
    the flux splatted is exactly that of those taken."""
    pin, rays, materials = view
    inside, outside = [0.0, 0.1], [2.9, 2.9]
    photons = _photons([inside, outside])
    image, keep = splat_subpixel(photons, np.full(2, 1e-10), pin, rays, materials, footprint=1.0)
    assert keep.tolist() == [False, True] and image.sum() > 0
    back = _photons([inside], normal=(0.0, 1.0, 0.0))
    image, keep = splat_subpixel(back, np.array([1e-10]), pin, rays, materials, footprint=1.0)
    assert keep.tolist() == [True] and not image.any()


def test_a_photon_hidden_from_the_camera_stays_in_the_gather(plane):
    """A photon above the mirror, seen from under it: the mirror is between."""
    from dataclasses import replace

    cam = replace(plane.camera, eye=(0.0, -0.5, 0.0), target=(0.0, H, 0.0))
    pin, rays = Pinhole.of(cam), SceneRays(plane.objects)
    photons = _photons([[0.0, 0.0]])
    image, keep = splat_subpixel(photons, np.array([1e-10]), pin, rays,
                                 receiver_materials(plane.objects), footprint=1.0)
    assert keep.tolist() == [True] and not image.any()
