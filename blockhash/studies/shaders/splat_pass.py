"""Photon splatting: the conserving estimate scattered from the photons onto the shading points
the camera sees directly (image-space photon mapping: McGuire & Luebke, HPG 2009; Mara, Luebke
& McGuire, I3D 2013), a peer of the cover gather (:mod:`blockhash.frame.cover_estimate`) in ``blockhash bench
--caustic``.

Each photon of the cover gather's records is one instanced quad, the screen rectangle of its
cube [p - h, p + h]^3 (glsl/splat_pass.vert); each fragment adds the photon's term
(glsl/caustic_cover_term.glsl, the gather's own) where its disc covers the pixel's shading
point, with additive blending.  A point seen in a mirror or through glass lies elsewhere than
where its photons project: splatting gives it nothing, and the bench reports the share of the
gathered caustic it reaches.  One shading point per pixel (the rasterised G-buffer).
"""

from __future__ import annotations

import time
from dataclasses import replace

import numpy as np

from blockhash.frame.caustic import MAX_MATERIALS, material_table, point_textures
from blockhash.frame.cover_estimate import require_conserving
from blockhash.frame.estimate import EstimateOptions
from blockhash.frame.shading_points import ShadingPoints
from blockhash.gl.context import check_gl, get_context, home_framebuffer
from blockhash.gl.shaderlib import compile_program, preprocess


class SplatPass:
    """Splat a :class:`~blockhash.index.lookups.cover.CoverGather`'s photons onto the shading points
    a scene camera (``Scene.camera``) sees, one per pixel."""

    def __init__(self, gather, *, backend=None):
        self.gather = gather
        self.ctx = get_context(backend)
        with self.ctx:
            records = gather.records if len(gather) else np.zeros((1, 8), np.uint32)
            self.vbo = self.ctx.buffer(np.ascontiguousarray(records).tobytes())
            check_gl(self.ctx, f"allocating the splat pass's {len(records):,} photons")

    def render(self, points: ShadingPoints, materials, camera, *, options=None,
               repeat: int = 1) -> tuple[np.ndarray, list[float]]:
        """((h, w, 3) float32 radiance times the path weight, the wall seconds of each of
        ``repeat`` draws)."""
        options = EstimateOptions() if options is None else options
        require_conserving(options)
        h, w = points.shape
        camera = replace(camera, width=w, height=h)  # one shading point per pixel
        kd, ks, e = material_table(materials)
        ctx = self.ctx
        with ctx:
            vs = preprocess("splat_pass.vert").text
            prog = compile_program(ctx, "splat_pass.frag", options.defines(), vertex=vs)
            texs = point_textures(ctx, points)
            out = ctx.texture((w, h), 4, dtype="f4")
            fbo = ctx.framebuffer(color_attachments=[out])
            vao = ctx.vertex_array(prog, [(self.vbo, "4f 4u /i", "in_position_h2", "in_payload")])
            try:
                check_gl(ctx, f"allocating the {w} x {h} splat pass")
                near = 1e-4 * float(np.linalg.norm(np.ptp(points.position.reshape(-1, 3), axis=0)))
                view_proj = camera.projection(max(near, 1e-6), 1e6) @ camera.view_matrix()
                prog["view_proj"].write(view_proj.T.astype(np.float32).tobytes())
                prog["splat_half_pixel"].value = (1.0 / w, 1.0 / h)
                prog["bh_power_scale"].value = float(self.gather.power_scale)
                for name, value in options.uniforms().items():
                    prog[name].value = value
                pad = MAX_MATERIALS - len(kd)
                prog["cp_kd"].value = [tuple(r) for r in np.vstack([kd, np.zeros((pad, 3))])]
                prog["cp_ks"].value = [tuple(r) for r in np.vstack([ks, np.zeros((pad, 3))])]
                prog["cp_exponent"].value = [float(x) for x in np.concatenate([e, np.zeros(pad)])]
                for unit, (name, tex) in enumerate(zip(("cp_position", "cp_normal", "cp_view"), texs)):
                    tex.use(unit)
                    prog[name].value = unit
                fbo.use()
                fbo.viewport = (0, 0, w, h)
                ctx.enable(ctx.BLEND)
                ctx.blend_func = ctx.ONE, ctx.ONE
                walls = []
                for _ in range(repeat):
                    fbo.clear(0.0, 0.0, 0.0, 0.0)
                    t = time.perf_counter()
                    vao.render(ctx.TRIANGLE_STRIP, vertices=4, instances=len(self.gather))
                    ctx.finish()
                    walls.append(time.perf_counter() - t)
                ctx.disable(ctx.BLEND)
                check_gl(ctx, "the splat pass draw")
                img = np.frombuffer(out.read(), dtype=np.float32).reshape(h, w, 4)[::-1, :, :3]
            finally:
                ctx.disable(ctx.BLEND)
                home_framebuffer(ctx).use()
                for obj in (*texs, out, fbo, vao):
                    obj.release()
        return np.ascontiguousarray(img * points.weight), walls

    def release(self) -> None:
        self.vbo.release()
