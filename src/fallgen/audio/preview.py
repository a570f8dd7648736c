"""Listening to and looking at dry fall sounds: WAV files and spectrogram PNGs."""

from __future__ import annotations

import io
from pathlib import Path

import cv2
import numpy as np
import soundfile as sf
from scipy.signal import spectrogram

from fallgen.atomic import write_bytes


def write_wav(path: str | Path, pressure_pa: np.ndarray, sample_rate: int) -> Path:
    """Float32 WAV of pressure in pascals at 1 m (no normalisation: 1.0 = 1 Pa = 94 dB SPL)."""
    buf = io.BytesIO()
    sf.write(buf, np.asarray(pressure_pa, np.float32), sample_rate, format="WAV",
             subtype="FLOAT")
    return write_bytes(path, buf.getvalue())


def spectrogram_png(path: str | Path, pressure_pa: np.ndarray, sample_rate: int,
                    title: str = "", floor_db: float = 0.0, top_db: float = 100.0) -> Path:
    """Spectrogram in dB SPL (re 20 uPa), 0-22 kHz, time left to right, with a title."""
    canvas = spectrogram_image(pressure_pa, sample_rate, title, floor_db, top_db)
    ok, enc = cv2.imencode(".png", canvas[:, :, ::-1])
    if not ok:
        raise OSError(f"could not encode {path}")
    return write_bytes(path, enc.tobytes())


def spectrogram_image(pressure_pa: np.ndarray, sample_rate: int, title: str = "",
                      floor_db: float = 0.0, top_db: float = 100.0,
                      size: tuple[int, int] = (800, 400)) -> np.ndarray:
    """The spectrogram of :func:`spectrogram_png` as an RGB image (size[1] + 40, size[0], 3)."""
    f, t, s = spectrogram(pressure_pa, fs=sample_rate, nperseg=1024, noverlap=768,
                          scaling="spectrum", mode="psd")
    db = 10 * np.log10(s + 1e-30) - 20 * np.log10(20e-6)
    v = np.clip((db - floor_db) / (top_db - floor_db), 0, 1)[::-1]  # high frequencies on top
    img = cv2.applyColorMap((v * 255).astype(np.uint8), cv2.COLORMAP_MAGMA)
    img = cv2.resize(img, size, interpolation=cv2.INTER_NEAREST)
    canvas = np.full((size[1] + 40, size[0], 3), 255, np.uint8)
    canvas[40:, :] = img
    label = f"{title}   0-{sample_rate // 2000} kHz, {len(pressure_pa) / sample_rate:.1f} s, " \
            f"{floor_db:.0f}-{top_db:.0f} dB SPL"
    cv2.putText(canvas, label, (8, 26), cv2.FONT_HERSHEY_SIMPLEX, 0.5, (0, 0, 0), 1,
                cv2.LINE_AA)
    return canvas[:, :, ::-1].copy()
