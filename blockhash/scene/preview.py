"""A quick pyrender view of a scene, for checking camera, objects and lights.

pyrender makes its own EGL context current on every render, and deleting an
``OffscreenRenderer`` calls eglTerminate, which breaks every moderngl context in
the process.  So the preview renders in a separate, spawned process
and sends back colour and depth arrays.
"""

from __future__ import annotations

import multiprocessing
import os

import numpy as np


def _render(meshes, colours, lights, camera, size):
    os.environ.setdefault("PYOPENGL_PLATFORM", "egl")
    import pyrender
    import trimesh

    scene = pyrender.Scene(ambient_light=np.full(3, 0.15), bg_color=np.zeros(4))
    for (vertices, faces, normals), colour in zip(meshes, colours):
        mesh = trimesh.Trimesh(vertices=vertices, faces=faces, vertex_normals=normals, process=False)
        material = pyrender.MetallicRoughnessMaterial(baseColorFactor=(*colour, 1.0), metallicFactor=0.0,
                                                      roughnessFactor=0.8)
        scene.add(pyrender.Mesh.from_trimesh(mesh, material=material, smooth=True))
    for kind, pose, intensity in lights:
        light = (pyrender.DirectionalLight if kind == "directional" else pyrender.PointLight)(
            color=np.ones(3), intensity=float(np.mean(intensity)))
        scene.add(light, pose=np.asarray(pose))
    pose, fov_y_deg = camera
    width, height = size
    cam = pyrender.PerspectiveCamera(yfov=np.radians(fov_y_deg), aspectRatio=width / height)
    scene.add(cam, pose=pose)
    renderer = pyrender.OffscreenRenderer(width, height)
    try:
        colour, depth = renderer.render(scene)
    finally:
        renderer.delete()
    return np.array(colour), np.array(depth)


def preview(scene, *, size=None):
    """(colour (h, w, 3) uint8, depth (h, w) float32 eye-space depth along the view axis, 0 where empty)."""
    size = size or (scene.camera.width, scene.camera.height)
    meshes = [(o.mesh.vertices, o.mesh.faces, o.mesh.vertex_normals) for o in scene.objects]
    colours = [tuple(o.material.tint if o.is_dielectric  # a flat preview: glass as its tint
                     else o.material.reflectance if o.is_specular
                     else np.clip(np.asarray(o.material.kd) + np.asarray(o.material.ks), 0, 1))
               for o in scene.objects]
    lights = [_preview_light(light) for light in scene.lights]
    cam = scene.camera
    camera = (np.linalg.inv(cam.view_matrix()), float(cam.fov_y_deg))
    with multiprocessing.get_context("spawn").Pool(1) as pool:
        return pool.apply(_render, (meshes, colours, lights, camera, tuple(size)))


def gbuffer_depth(camera, gbuffer) -> np.ndarray:
    """Eye-space depth of each G-buffer pixel along the view axis (0 where nothing is hit)."""
    view = camera.view_matrix()
    p = gbuffer.position.reshape(-1, 3).astype(np.float64)
    z = -(p @ view[2, :3] + view[2, 3])
    return np.where(gbuffer.object.reshape(-1) >= 0, z, 0.0).reshape(gbuffer.object.shape)


def _preview_light(light):
    """(kind, pose (4, 4), intensity) of a pyrender light standing in for ``light``: a point
    light of the same intensity (W/sr; a spot's power fills its cone), an area light as a
    point at its centre a little in front of it with its intensity along the normal (L A,
    its power over pi), a directional light as pyrender's, shining along its direction, an
    environment as a directional light from its brightest cell (its radiance over the sphere
    over pi)."""
    pose = np.eye(4)
    if hasattr(light, "image"):  # an environment: a sun from its brightest cell
        h, w = light.image.shape[:2]
        j, i = divmod(int(np.argmax(light.cell_pmf)), w)
        phi = 2.0 * np.pi * (i + 1.0) / w  # the cell's centre (its columns start half a pixel on)
        theta = np.pi * (j + 0.5) / (h - 1)
        z = light.to_world @ [np.sin(phi) * np.sin(theta), np.cos(theta),
                              -np.cos(phi) * np.sin(theta)]
        x = np.cross([0.0, 1.0, 0.0] if abs(z[1]) < 0.9 else [1.0, 0.0, 0.0], z)
        x /= np.linalg.norm(x)
        pose[:3, :3] = np.stack([x, np.cross(z, x), z], axis=1)
        return "directional", pose.tolist(), tuple(np.asarray(light.integral) / np.pi)
    if hasattr(light, "irradiance"):
        z = -np.asarray(light.direction, dtype=np.float64)  # pyrender's light shines along -z
        x = np.cross([0.0, 1.0, 0.0] if abs(z[1]) < 0.9 else [1.0, 0.0, 0.0], z)
        x /= np.linalg.norm(x)
        pose[:3, :3] = np.stack([x, np.cross(z, x), z], axis=1)
        return "directional", pose.tolist(), tuple(light.irradiance)
    if hasattr(light, "radiance"):
        tri = light.triangles
        w = light.face_areas / light.area
        normal = (light.face_normals * w[:, None]).sum(axis=0)
        pose[:3, 3] = (tri.mean(axis=1) * w[:, None]).sum(axis=0) + 1e-3 * normal
        return "point", pose.tolist(), tuple(np.asarray(light.power) / np.pi)
    pose[:3, 3] = light.position
    return "point", pose.tolist(), tuple(np.asarray(light.power) / getattr(light, "solid_angle", 4 * np.pi))
