"""Animations from a folder of frames: every PNG sorted by name, written as an animated GIF or an MP4."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ._common import AnalysisError
from .color import save_animation

__all__ = ["frame_files", "read_frames", "animate_folder"]


def frame_files(folder):
    """The PNG files of a folder (``*.png``, any case, hidden files left out), sorted by name.

    Signature: ``frame_files(folder) -> list[Path]``.
    """
    folder = Path(folder)
    if not folder.is_dir():
        raise AnalysisError(f"{folder}: no such folder" if not folder.exists() else f"{folder}: not a folder")
    files = sorted((p for p in folder.iterdir()
                    if p.is_file() and p.suffix.lower() == ".png" and not p.name.startswith(".")),
                   key=lambda p: p.name)
    if not files:
        raise AnalysisError(f"{folder}: the folder holds no PNG frame")
    return files


def read_frames(files):
    """Read PNG files as (H, W, 3) uint8 RGB arrays (grey and palette images become RGB; an alpha channel is
    dropped). All frames must have the same size.

    Signature: ``read_frames(files) -> list of (H, W, 3) uint8``.
    """
    from PIL import Image, UnidentifiedImageError

    frames, first = [], None
    for p in files:
        try:
            with Image.open(p) as im:
                if im.format != "PNG":
                    raise AnalysisError(f"{p}: not a PNG image ({im.format})")
                frame = np.asarray(im.convert("RGB"), dtype=np.uint8)
        except UnidentifiedImageError:
            raise AnalysisError(f"{p}: not a PNG image") from None
        if first is None:
            first = (p, frame.shape)
        elif frame.shape != first[1]:
            raise AnalysisError(f"{p.name} is {frame.shape[1]} x {frame.shape[0]} px but {first[0].name} is "
                                f"{first[1][1]} x {first[1][0]} px: every frame must have the same size")
        frames.append(frame)
    return frames


def animate_folder(folder, path, *, fps=4.0, loop=0):
    """Every PNG of ``folder``, sorted by name, as an animation at ``path`` (``.gif`` or ``.mp4``, chosen by the
    extension; written atomically by :func:`analysis.color.save_animation`).

    Signature: ``animate_folder(folder, path, *, fps=4.0, loop=0) -> dict`` with ``output``, ``frames`` (count),
    ``first``, ``last`` (file names), ``width_px``, ``height_px``, ``fps`` and ``duration_s``.
    """
    suffix = Path(path).suffix.lower()
    if suffix not in (".gif", ".mp4"):
        raise AnalysisError(f"unsupported animation format {suffix or Path(path).name!r}: use .gif or .mp4")
    fps = float(fps)
    if not (np.isfinite(fps) and fps > 0):
        raise AnalysisError(f"fps must be a positive number, got {fps:g}")
    files = frame_files(folder)
    frames = read_frames(files)
    save_animation(frames, path, fps=fps, loop=loop)
    h, w = frames[0].shape[:2]
    return {"output": str(path), "frames": len(frames), "first": files[0].name, "last": files[-1].name,
            "width_px": int(w), "height_px": int(h), "fps": fps, "duration_s": len(frames) / fps}
