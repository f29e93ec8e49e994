"""Textures kept per context and reused from pass to pass: a render's passes upload maps of
about the same size every pass, and textures allocated and freed anew each time fragment the
process's heap (llvmpipe keeps texture storage in ordinary memory), so that its peak grows
with the passes.

A pooled texture is found by its role and shape: the same width, format and components, and
at least the rows asked for (grown when a pass needs more, never shrunk).  The rows past
those written hold stale data that no shader reads: every pooled texture is addressed by its
element index (``blockhash.gl.packing``'s wrapped rows) or by pixel within the image size.
One object holds a role's texture at a time; a second holder of the same role in the same
context gets a texture of its own, released as usual (:func:`give_back`).
"""

from __future__ import annotations

from blockhash.gl import strict
from blockhash.gl.context import check_gl

#: Spare rows allocated when a pooled texture grows, as a share of the rows asked for.
GROWTH = 0.125


def _pool(ctx) -> dict:
    extra = ctx.extra if isinstance(ctx.extra, dict) else {}
    ctx.extra = extra
    return extra.setdefault("texture_pool", {})


def pooled_texture(ctx, role: str, width: int, height: int, components: int, dtype: str, *,
                   exact: bool = False):
    """A texture of ``width`` x at least ``height`` texels (``exact``: exactly ``height``, for
    images read back whole) for ``role`` from ``ctx``'s pool (call with ``ctx`` current); hand
    it back with :func:`give_back`."""
    pool = _pool(ctx)
    key = (role, int(width), int(components), dtype)
    tex = pool.get(key)
    if tex is not None and tex.extra.get("busy"):
        tex = ctx.texture((width, height), components, dtype=dtype)  # a second holder
        check_gl(ctx, f"allocating the {role} texture ({width} x {height} x {components})")
        tex.extra = {"pooled": False}
        strict.poison(tex)
        return tex
    if tex is None or tex.height < height or (exact and tex.height != height):
        if tex is not None:
            tex.release()
        rows = height if exact else min(height + int(height * GROWTH),
                                        ctx.info["GL_MAX_TEXTURE_SIZE"])
        tex = ctx.texture((width, rows), components, dtype=dtype)
        check_gl(ctx, f"allocating the {role} texture ({width} x {rows} x {components})")
        pool[key] = tex
    tex.extra = {"pooled": True, "busy": True}
    strict.poison(tex)  # its stale rows too
    return tex


def give_back(obj) -> None:
    """Return a pooled texture to its pool; release anything else (textures, framebuffers)."""
    extra = getattr(obj, "extra", None)
    if isinstance(extra, dict) and extra.get("pooled"):
        extra["busy"] = False
    else:
        obj.release()


def release_pool(ctx) -> None:
    """Release every texture in ``ctx``'s pool (with ``ctx`` current)."""
    for tex in _pool(ctx).values():
        tex.release()
    _pool(ctx).clear()
