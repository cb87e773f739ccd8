#!/usr/bin/env python3
"""Save one frame of a video as a PNG (`make figures` uses it for the README's still of the twin's
video): the frame at a time, or the last one (the verdict). Reads with imageio-ffmpeg (extra [video]).

usage: .venv/bin/python tools/video_still.py IN.mp4 OUT.png [SECONDS|last]
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
from imageio_ffmpeg import read_frames
from PIL import Image


def main(video: Path, out: Path, at: str) -> None:
    reader = read_frames(str(video))
    meta = next(reader)
    w, h = meta["size"]
    index = None if at == "last" else round(float(at) * meta["fps"])
    frame = None
    for k, raw in enumerate(reader):
        frame = raw
        if k == index:
            break
    reader.close()
    if frame is None or (index is not None and k < index):
        sys.exit(f"{video}: no frame at {at} s (the video is {meta['duration']:.1f} s long)")
    Image.fromarray(np.frombuffer(frame, dtype=np.uint8).reshape(h, w, 3)).save(out)
    print(f"wrote {out} ({w} x {h}, {'the last frame' if index is None else f'{at} s in'})")


if __name__ == "__main__":
    if len(sys.argv) not in (3, 4):
        sys.exit(__doc__)
    main(Path(sys.argv[1]), Path(sys.argv[2]), sys.argv[3] if len(sys.argv) == 4 else "last")
