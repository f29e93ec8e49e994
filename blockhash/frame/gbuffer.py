"""The G-buffer: what each pixel sees, rasterised with moderngl.

One draw of every scene triangle (per-corner shading normals, so smooth ring
walls stay smooth) into two RGBA32F targets: world position with the object id
(-1 where nothing is hit) and the unit shading normal turned toward the camera, with
which face of its triangle the camera sees (for one-sided receivers).  Rows are returned
top to bottom.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from blockhash.errors import CapacityError
from blockhash.gl.context import check_gl, get_context, home_framebuffer
from blockhash.scene.camera import Pinhole

VERTEX = """#version 450 core
uniform mat4 view_proj;
in vec3 in_position;
in vec3 in_normal;
in float in_object;
out vec3 v_position;
out vec3 v_normal;
flat out float v_object;
void main() {
    v_position = in_position;
    v_normal = in_normal;
    v_object = in_object;
    gl_Position = view_proj * vec4(in_position, 1.0);
}
"""

FRAGMENT = """#version 450 core
uniform vec3 eye;
in vec3 v_position;
in vec3 v_normal;
flat in float v_object;
layout(location = 0) out vec4 out_position;
layout(location = 1) out vec4 out_normal;
void main() {
    // Vertex normals that cancel (or are zero) have no direction: the face's normal instead,
    // as the ray caster takes it (raycast.hit_frame); normalize(0) is NaN
    vec3 n = v_normal;
    if (!(dot(n, n) > 1e-24)) {
        n = cross(dFdx(v_position), dFdy(v_position));
        if (!(dot(n, n) > 0.0)) {
            n = eye - v_position;  // a triangle seen edge on, thinner than a pixel
        }
    }
    n = normalize(n);
    if (dot(n, eye - v_position) < 0.0) {
        n = -n;  // the side the camera sees (front or back: out_normal.w)
    }
    out_position = vec4(v_position, v_object);
    // w: 1 where the camera sees the triangle's front face (counter-clockwise on screen,
    // the side its face normal points to), 0 on its back; the clear colour's -1 elsewhere
    out_normal = vec4(n, gl_FrontFacing ? 1.0 : 0.0);
}
"""


@dataclass(frozen=True)
class GBuffer:
    """position (h, w, 3) float32; normal (h, w, 3) float32; object (h, w) int32, -1 for none;
    front (h, w) bool: the camera sees the front face of the triangle (the side its face
    normal points to), or None where the G-buffer's maker did not say (the shading points
    then cast the camera ray again where they need it, :func:`.shading.shading_points`).
    Where nothing is hit the position is one unit along the camera ray from where it started
    (the shading points read the direction an environment light is seen along from it)."""

    position: np.ndarray
    normal: np.ndarray
    object: np.ndarray
    front: np.ndarray | None = None
    #: (h, w, 3) float64 where each camera ray started, for a thin lens (None: the eye).
    origin: np.ndarray | None = None


def scene_triangles(objects) -> np.ndarray:
    """(3 T, 7) float32 corners: position, shading normal, object index."""
    parts = []
    for i, obj in enumerate(objects):
        mesh = obj.mesh
        corners = mesh.faces.reshape(-1)
        parts.append(np.concatenate([mesh.vertices[corners], mesh.vertex_normals[corners],
                                     np.full((len(corners), 1), float(i))], axis=1))
    return np.concatenate(parts).astype(np.float32)


def rasterize(camera, objects, *, size=None, backend=None) -> GBuffer:
    """Rasterise ``objects`` seen by ``camera`` at ``size`` = (width, height) or the camera's."""
    width, height = size or (camera.width, camera.height)
    ctx = get_context(backend)
    limit = min(ctx.info["GL_MAX_TEXTURE_SIZE"], *ctx.info["GL_MAX_VIEWPORT_DIMS"])
    if not (0 < width <= limit and 0 < height <= limit):
        raise CapacityError.about("image size {width} x {height} is outside 1..{limit:,} per "
                                  "side (GL_MAX_TEXTURE_SIZE / GL_MAX_VIEWPORT_DIMS of this "
                                  "device); render a smaller image ({size})", width=width,
                                  height=height, limit=limit)
    tris = scene_triangles(objects)
    radius = float(np.linalg.norm(tris[:, :3] - np.asarray(camera.eye, dtype=np.float32), axis=1).max())
    # The camera's own matrices, at the rendered size (the aspect may differ from the file's).
    view_proj = replace(camera, width=width, height=height).projection(radius * 1e-4, radius * 2.0) \
        @ camera.view_matrix()
    with ctx:
        prog = ctx.program(vertex_shader=VERTEX, fragment_shader=FRAGMENT)
        vbo = ctx.buffer(tris.tobytes())
        vao = ctx.vertex_array(prog, [(vbo, "3f 3f 1f", "in_position", "in_normal", "in_object")])
        targets = [ctx.texture((width, height), 4, dtype="f4") for _ in range(2)]
        depth = ctx.depth_renderbuffer((width, height))
        fbo = ctx.framebuffer(color_attachments=targets, depth_attachment=depth)
        check_gl(ctx, f"allocating a {width} x {height} G-buffer")
        try:
            prog["view_proj"].write(view_proj.T.astype(np.float32).tobytes())
            prog["eye"].value = tuple(float(x) for x in camera.eye)
            fbo.use()
            fbo.viewport = (0, 0, width, height)
            fbo.clear(0.0, 0.0, 0.0, -1.0, depth=1.0)
            ctx.enable(ctx.DEPTH_TEST)
            vao.render()
            ctx.disable(ctx.DEPTH_TEST)
            check_gl(ctx, "the G-buffer draw")
            pos = np.frombuffer(targets[0].read(), dtype=np.float32).reshape(height, width, 4)[::-1]
            nrm = np.frombuffer(targets[1].read(), dtype=np.float32).reshape(height, width, 4)[::-1]
        finally:
            home_framebuffer(ctx).use()
            for obj in (vao, vbo, prog, fbo, depth, *targets):
                obj.release()
    obj_id = np.where(pos[..., 3] >= 0, np.rint(pos[..., 3]), -1).astype(np.int32)
    pos = np.array(pos[..., :3])
    miss = obj_id < 0
    if miss.any():  # one unit along the ray through the pixel's centre (GBuffer)
        rows, cols = np.nonzero(miss)  # the missed pixels' rays only, in pos[miss]'s order
        rays = Pinhole.of(camera, (width, height)).film_rays(cols + 0.5, rows + 0.5)
        pos[miss] = (np.asarray(camera.eye, dtype=np.float64) + rays).astype(np.float32)
    return GBuffer(position=pos,
                   normal=np.ascontiguousarray(nrm[..., :3]), object=obj_id,
                   front=nrm[..., 3] > 0.5)
