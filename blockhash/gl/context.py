"""Offscreen OpenGL contexts: EGL by default, OSMesa when asked or when EGL fails.

Both give GL 4.5 core on Mesa's llvmpipe (or a GPU's driver under EGL).  One
context per process and backend is created on first use and reused.
moderngl reports failed allocations through ``ctx.error`` rather than by
raising, so :func:`check_gl` is called after every large allocation.
"""

from __future__ import annotations

import os

import moderngl

from blockhash.errors import CapacityError, GLUnavailableError

BACKENDS = ("auto", "egl", "osmesa")
#: GL 4.5 core: integer textures, texelFetch, SSBO writes from fragment shaders.
REQUIRED_GL = 450
#: System packages that provide each backend (Debian names).
PACKAGES = {"egl": "libegl1 libegl-mesa0 libgl1-mesa-dri", "osmesa": "libosmesa6"}

_contexts: dict[str, moderngl.Context] = {}


def _create(backend: str) -> moderngl.Context:
    if backend == "egl":
        return moderngl.create_standalone_context(backend="egl", require=REQUIRED_GL)
    from blockhash.gl.osmesa import OSMesaLoader

    loader = OSMesaLoader()
    previous = moderngl._store.default_context
    moderngl._store.default_context = None
    try:
        moderngl.init_context(loader=loader)
        ctx = moderngl.get_context()
    finally:
        moderngl._store.default_context = previous
    ctx.extra = {"osmesa_loader": loader}
    if ctx.version_code < REQUIRED_GL:
        raise GLUnavailableError(f"OSMesa gave GL {ctx.version_code}, need {REQUIRED_GL}")
    return ctx


def get_context(backend: str | None = None) -> moderngl.Context:
    """The shared context of ``backend``.

    Parameters
    ----------
    backend : {'auto', 'egl', 'osmesa'}, optional
        Default: the ``BLOCKHASH_GL`` environment variable, else 'auto' (EGL, then OSMesa).
    """
    backend = backend or os.environ.get("BLOCKHASH_GL", "auto")
    if backend not in BACKENDS:
        raise GLUnavailableError(f"GL backend {backend!r} is not known; choose one of {', '.join(BACKENDS)}")
    tries = ["egl", "osmesa"] if backend == "auto" else [backend]
    failures = []
    for name in tries:
        if name in _contexts:
            return _contexts[name]
        try:
            ctx = _create(name)
        except Exception as exc:  # noqa: BLE001 - each backend fails in its own library's way
            failures.append(f"{name}: {exc}")
            continue
        ctx.extra = {**(ctx.extra or {}), "backend": name}
        with ctx:
            _ = ctx.info  # cached now, while current: read later under another context it is junk
        _contexts[name] = ctx
        return ctx
    packages = " / ".join(f"{name}: {PACKAGES[name]}" for name in tries)
    raise GLUnavailableError(
        "no OpenGL 4.5 context could be created; tried " + "; ".join(failures)
        + f". Install the system packages ({packages}) or choose another backend with "
          "BLOCKHASH_GL=egl|osmesa")


def open_contexts() -> dict[str, moderngl.Context]:
    """The contexts :func:`get_context` has created so far, by backend."""
    return dict(_contexts)


def backend_of(ctx: moderngl.Context) -> str:
    return (ctx.extra or {}).get("backend", "?")


def check_gl(ctx: moderngl.Context, what: str) -> None:
    """Raise if the last GL calls failed (moderngl sets ctx.error instead of raising)."""
    err = ctx.error
    if err in ("GL_OUT_OF_MEMORY", "GL_INVALID_VALUE"):
        raise CapacityError(f"OpenGL reported {err} after {what}; the data does not fit this "
                            "device: use fewer photons, a smaller index or a smaller image")
    if err != "GL_NO_ERROR":
        raise GLUnavailableError(f"OpenGL reported {err} after {what}")


def home_framebuffer(ctx: moderngl.Context):
    """A 1x1 framebuffer kept for the context's lifetime.

    moderngl rebinds its idea of the current framebuffer after creating a new one,
    so a framebuffer about to be released must never be left current: make this
    one current first.  It is never released.
    """
    extra = ctx.extra if ctx.extra is not None else {}
    ctx.extra = extra
    if "home_fbo" not in extra:
        extra["home_fbo"] = ctx.framebuffer(color_attachments=[ctx.renderbuffer((1, 1))])
    return extra["home_fbo"]


#: Limits printed by ``blockhash info`` and checked before packing.
LIMIT_NAMES = ("GL_MAX_TEXTURE_SIZE", "GL_MAX_3D_TEXTURE_SIZE", "GL_MAX_ARRAY_TEXTURE_LAYERS",
               "GL_MAX_SHADER_STORAGE_BLOCK_SIZE", "GL_MAX_FRAGMENT_UNIFORM_COMPONENTS",
               "GL_MAX_VIEWPORT_DIMS", "GL_MAX_RENDERBUFFER_SIZE", "GL_MAX_COLOR_ATTACHMENTS")


def gl_info(ctx: moderngl.Context) -> dict:
    """Renderer, version, backend and the limits that matter here."""
    info = ctx.info
    out = {"backend": backend_of(ctx), "renderer": info.get("GL_RENDERER"),
           "vendor": info.get("GL_VENDOR"), "version": info.get("GL_VERSION"),
           "version_code": ctx.version_code}
    for name in LIMIT_NAMES:
        if name in info:
            out[name] = info[name]
    return out


#: The GL timer query result as moderngl reads it (32 bits of nanoseconds) saturates here.
GPU_TIMER_LIMIT_NS = 2**32 - 1


def draw_fullscreen(ctx: moderngl.Context, program, fbo, size: tuple[int, int]) -> float:
    """One fullscreen-triangle draw of ``program`` into ``fbo``; returns the draw's seconds.

    The time covers the draw alone (the pipeline is drained before and after), not
    compilation or transfers; llvmpipe compiles a program at its first draw.
    """
    return draw_timed(ctx, program, fbo, size)[0]


def draw_timed(ctx: moderngl.Context, program, fbo, size: tuple[int, int],
               *, repeat: int = 1) -> tuple[float, float]:
    """``repeat`` back-to-back fullscreen draws; returns (wall seconds, GPU seconds) of the last.

    GPU time is a GL timer query (GL_TIME_ELAPSED) around the draw; wall time is taken
    with the pipeline drained before and after.  Use :func:`time_draws` for statistics.
    """
    walls, gpus = time_draws(ctx, program, fbo, size, repeat=repeat, warmup=0)
    return walls[-1], gpus[-1]


def time_draws(ctx: moderngl.Context, program, fbo, size: tuple[int, int], *, repeat: int = 10,
               warmup: int = 2) -> tuple[list[float], list[float]]:
    """Time ``repeat`` draws of one program after ``warmup`` untimed draws of the same program.

    Returns (wall seconds, GPU seconds), one of each per timed draw.  Draws run back to
    back with no read-back between them; each is wrapped in its own timer query and the
    pipeline is drained after it (the wall time then includes the driver's submission).
    The warm-up compiles the program (llvmpipe compiles at the first draw) and lets a GPU
    leave its idle clock.
    """
    import time

    fbo.use()
    fbo.viewport = (0, 0, *size)
    vao = ctx.vertex_array(program, [])
    walls, gpus = [], []
    try:
        for _ in range(warmup):
            vao.render(mode=ctx.TRIANGLES, vertices=3)
        ctx.finish()
        for _ in range(repeat):
            query = ctx.query(time=True)
            start = time.perf_counter()
            with query:
                vao.render(mode=ctx.TRIANGLES, vertices=3)
            ctx.finish()
            walls.append(time.perf_counter() - start)
            # moderngl reads the 32-bit query result, which saturates at 2^32 - 1 ns
            # (4.29 s, reached only on a software rasterizer): no figure then.
            gpus.append(query.elapsed * 1e-9 if query.elapsed < GPU_TIMER_LIMIT_NS else float("nan"))
        return walls, gpus
    finally:
        vao.release()


def bind_textures(program, textures: dict) -> None:
    """Bind each named texture to its own unit and point the program's sampler at it."""
    for unit, (name, tex) in enumerate(textures.items()):
        tex.use(location=unit)
        if name in program:
            program[name].value = unit
