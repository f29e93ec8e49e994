"""``blockhash render SCENE --frames``: the frames of an animated scene as numbered EXR and PNG
files and a video (:mod:`blockhash.passes.frames` renders them)."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

from blockhash.cli.args import FLAGS, INTERRUPTED
from blockhash.errors import InputError


def frame_path(out: Path, frame: int, suffix: str) -> Path:
    """``OUT-0007.exr`` (or another suffix) of frame 7 for the output ``OUT.exr``."""
    return out.with_name(f"{out.stem}-{frame:04d}{suffix}")


class FrameWriter:
    """Writes each frame's EXR (its layers) and PNG, and the video: one exposure for every
    frame (the first frame's white point), so the tone mapping does not flicker."""

    def __init__(self, out: Path, fps: float):
        self.out, self.fps = out, fps
        self.white = None
        self.video = None
        self.pixels = []

    def add(self, frame: int, result) -> None:
        from blockhash.evaluate.images import srgb, white_point, write_exr, write_rgb8

        write_exr(frame_path(self.out, frame, ".exr"), result.layers(), {
            "blockhash:frame": frame, "blockhash:spp": result.spp,
            "blockhash:passes": result.passes})
        if self.white is None:
            self.white = white_point(result.combined)
        rgb8 = np.round(srgb(result.combined, white=self.white) * 255).astype(np.uint8)
        write_rgb8(frame_path(self.out, frame, ".png"), rgb8)
        self.pixels.append(rgb8)

    def close(self) -> Path | None:
        """Write the video of the frames added (None without any)."""
        if not self.pixels:
            return None
        import imageio.v2 as imageio

        path = self.out.with_suffix(".mp4")
        with imageio.get_writer(str(path), fps=self.fps, codec="libx264", quality=8,
                                macro_block_size=2, ffmpeg_log_level="error") as video:
            for rgb8 in self.pixels:
                video.append_data(_even(rgb8))
        return path


def _even(rgb8: np.ndarray) -> np.ndarray:
    """The frame padded to even sides (H.264's 4:2:0 needs them), edge pixels repeated."""
    h, w, _ = rgb8.shape
    return np.pad(rgb8, ((0, h % 2), (0, w % 2), (0, 0)), mode="edge")


def render_animation(args, scene, out: Path, plan) -> int:
    from blockhash.cli.estimate import options_from
    from blockhash.frame.options import LookupOptions
    from blockhash.passes.frames import frame_range, render_frames

    if scene.animation is None:
        raise InputError(f"{args.scene}: --frames needs an [animation] table in the scene "
                         "(blockhash/scene/animation.py lists its keys); leave --frames out "
                         "to render a still")
    try:
        frames = frame_range(args.frames, scene.animation.frames)
    except InputError as exc:  # frame_range's text is --frames here
        raise InputError(exc.spelled({**FLAGS, "text": "--frames "})) from None
    writer = FrameWriter(out, scene.animation.fps)
    bar = None
    if sys.stderr.isatty():
        from tqdm.auto import tqdm

        bar = tqdm(total=len(frames), unit="frame", desc="frames", file=sys.stderr)

    def on_frame(f, renderer, seconds):
        writer.add(f, renderer.image)
        if bar is not None:
            bar.update(1)
        else:
            print(f"frame {f}: {renderer.passes} passes in {seconds:.2f} s", file=sys.stderr)

    try:
        seconds = render_frames(
            scene, frames, photons=args.photons, spp=args.spp, seed=args.seed,
            estimate=options_from(args), backend=args.backend, plan=plan,
            lookup=LookupOptions(method=args.method, k=args.k, A=args.A, variant=args.variant),
            on_frame=on_frame)
    except KeyboardInterrupt:
        if bar is not None:
            bar.close()
        video = writer.close()
        print(f"blockhash render: interrupted (Ctrl-C); kept {len(writer.pixels)} frame(s)"
              + (f" and their video {video}" if video else ""), file=sys.stderr)
        return INTERRUPTED
    if bar is not None:
        bar.close()
    video = writer.close()
    times = list(seconds.values())
    later = float(np.median(times[1:])) if len(times) > 1 else float("nan")
    print(f"scene: {args.scene} -> {frame_path(out, frames[0], '.exr').name} .. "
          f"{frame_path(out, frames[-1], '.exr').name} (+ .png), video {video}")
    print(f"frames: {len(times)} at {scene.animation.fps:g} fps; seconds a frame: first "
          f"{times[0]:.2f}, median of the rest {later:.2f} ({1.0 / later:.2f} frames a second "
          "rendered, files written apart); "
          + ("the camera alone moves: every frame gathers the first frame's photons"
             if not scene.animation.moves_photons else
             "lights or objects move: each frame traces its photons from the same streams"))
    return 0
