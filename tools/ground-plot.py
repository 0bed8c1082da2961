#!/usr/bin/env python3
"""What `rain-composite inspect ground` finds over each sample clip, as one small plot.

For every clip given, the ground is inspected every STEP seconds; one panel a clip shows,
against time, the horizon row where it lies in the picture (the panel's top is the picture's
top, its bottom the picture's bottom; the 2 s aggregate white, the single frame's grey; rows
off the picture at the edge) and the confidence (orange, 0 at the bottom, 1 at the top), with
the 0.9 a ground needs to engage (dotted). Needs numpy and an ffmpeg with drawtext.

    tools/ground-plot.py -o docs/ground-plot.jpg samples/*.mp4
"""

import argparse
import json
import os
import subprocess
import tempfile

import numpy as np

W, H, LEFT, STEP = 560, 90, 110, 0.25


def inspect(binary, clip, t):
    out = subprocess.run(
        [binary, "inspect", "ground", clip, "--at", f"{t:.3f}", "--json", "-q"],
        capture_output=True, text=True, check=True,
    ).stdout
    return json.loads(out)


def duration(clip):
    out = subprocess.run(
        ["ffprobe", "-v", "error", "-show_entries", "format=duration", "-of", "csv=p=0", clip],
        capture_output=True, text=True, check=True,
    ).stdout
    return float(out)


def line(img, xs, ys, colour, dotted=False):
    """Draws the polyline through (xs, ys) in panel pixels, 2 px thick."""
    for (x0, y0), (x1, y1) in zip(zip(xs, ys), zip(xs[1:], ys[1:])):
        n = int(max(abs(x1 - x0), abs(y1 - y0))) + 1
        for k in range(n + 1):
            if dotted and (k // 4) % 2:
                continue
            x = int(round(x0 + (x1 - x0) * k / n))
            y = int(round(y0 + (y1 - y0) * k / n))
            img[max(y - 1, 0):y + 1, max(x - 1, 0):x + 1] = colour


def panel(binary, clip):
    img = np.full((H, W, 3), 24, np.uint8)
    img[:, LEFT - 1] = 90
    end = duration(clip)
    times = np.arange(0.0, end - 1e-6, STEP)
    found = [inspect(binary, clip, t) for t in times]
    px = lambda t: LEFT + 4 + (W - LEFT - 8) * t / end
    py = lambda v: 4 + (H - 8) * (1.0 - min(max(v, 0.0), 1.0))
    for v in (0.0, 0.5, 1.0):
        img[int(py(v)), LEFT:] = 60
    xs = [px(t) for t in times]
    line(img, [px(0), px(end)], [py(0.9), py(0.9)], (200, 200, 200), dotted=True)
    # The horizon where it lies in the picture: its row down from the panel's top.
    line(img, xs, [py(1.0 - f["frame"]["horizon_row"]) for f in found], (120, 120, 120))
    line(img, xs, [py(1.0 - f["horizon_row"]) for f in found], (255, 255, 255))
    line(img, xs, [py(f["confidence"]) for f in found], (255, 150, 40))
    return img


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("clips", nargs="+")
    ap.add_argument("-o", "--output", required=True, help="the plot (JPEG or PNG)")
    ap.add_argument("--binary", default="rain-composite")
    a = ap.parse_args()
    legend = np.full((22, W, 3), 24, np.uint8)
    img = np.concatenate([panel(a.binary, c) for c in a.clips] + [legend])
    with tempfile.TemporaryDirectory() as tmp:
        raw = os.path.join(tmp, "plot.ppm")
        with open(raw, "wb") as f:
            f.write(b"P6 %d %d 255\n" % (img.shape[1], img.shape[0]) + img.tobytes())
        text = ",".join(
            f"drawtext=text='{os.path.basename(c)}':x=8:y={i * H + 8}:fontcolor=white:fontsize=14"
            for i, c in enumerate(a.clips)
        )
        text += (f",drawtext=text='horizon row from the top (white; one frame grey)   confidence (orange)  0.9 (dots)"
                 f"   0–{duration(a.clips[0]):.0f} s':x=8:y={img.shape[0] - 16}"
                 ":fontcolor=white:fontsize=11")
        subprocess.run(["ffmpeg", "-loglevel", "error", "-y", "-i", raw, "-vf", text, "-q:v", "3",
                        a.output], check=True)


if __name__ == "__main__":
    main()
