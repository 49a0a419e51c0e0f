#!/usr/bin/env python3
"""Writes the relative standard error of luz EXRs as a grey PNG, side by side.

Each pixel shows its largest relative standard error over the channels,
stderr / max(mean, 0.1) (the measure of --noise-threshold), black at 0 and
white at --scale (default 0.25) or above.

    tools/stderr_png.py OUT.png A.exr [B.exr ...] [--scale 0.25]

Needs numpy and the OpenEXR module (pip install numpy OpenEXR).
"""
import argparse
import struct
import sys
import zlib

import numpy as np
import OpenEXR


def relative_stderr(path):
    channels = OpenEXR.File(path).channels()
    if "stderr" not in channels or "RGB" not in channels:
        sys.exit(f"{path}: no RGB and stderr channels (not a luz EXR?)")
    mean = channels["RGB"].pixels.astype(np.float64)
    stderr = channels["stderr"].pixels.astype(np.float64)
    return np.max(stderr / np.maximum(mean, 0.1), axis=-1)


def write_png(path, grey):
    height, width = grey.shape
    rows = b"".join(b"\0" + row.tobytes() for row in grey)

    def chunk(kind, data):
        body = kind + data
        return struct.pack(">I", len(data)) + body + struct.pack(">I", zlib.crc32(body))

    header = struct.pack(">IIBBBBB", width, height, 8, 0, 0, 0, 0)
    with open(path, "wb") as f:
        f.write(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header))
        f.write(chunk(b"IDAT", zlib.compress(rows, 9)) + chunk(b"IEND", b""))


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out")
    parser.add_argument("exrs", nargs="+")
    parser.add_argument("--scale", type=float, default=0.25)
    args = parser.parse_args()
    images = [relative_stderr(p) for p in args.exrs]
    if len({i.shape for i in images}) != 1:
        sys.exit("the EXRs differ in size")
    gap = np.ones((images[0].shape[0], 4))
    joined = np.concatenate(sum(([i / args.scale, gap] for i in images), [])[:-1], axis=1)
    write_png(args.out, (np.clip(joined, 0, 1) * 255 + 0.5).astype(np.uint8))


if __name__ == "__main__":
    main()
