"""Joins chunks rendered with `rain-composite --frames A..B` into one file, losslessly.

`ffmpeg -f concat -c copy` places each file after the previous one by the file's duration. A
chunk's own duration is not the right one: its audio may end up to one audio packet past its
last frame, and a muxer may shift a chunk's timestamps (Matroska moves negative ones, such as
AAC priming, to zero). So each entry's `duration` is where the chunk's video ends, measured
from the chunk's start, less how far the next chunk's video starts after that chunk's start:
the next chunk's first frame then lands exactly one frame after this chunk's last.
"""

import json
import os
import subprocess
import sys
from fractions import Fraction


def _probe(path):
    out = subprocess.run(
        ["ffprobe", "-v", "error", "-print_format", "json", "-show_format",
         "-show_packets", "-select_streams", "v:0", path],
        check=True, capture_output=True, text=True).stdout
    info = json.loads(out)
    start = Fraction(info["format"]["start_time"])
    packets = info["packets"]
    pts = [Fraction(p["pts_time"]) for p in packets]
    end = max(Fraction(p["pts_time"]) + Fraction(p["duration_time"]) for p in packets)
    return start, min(pts), end


def concat_list(chunks):
    """The text of an ffmpeg concat list joining `chunks` (paths, in order)."""
    probed = [_probe(c) for c in chunks]
    lines = ["ffconcat version 1.0"]
    for i, path in enumerate(chunks):
        # ffmpeg reads a relative name against the list's folder, not the current one.
        path = os.path.abspath(path)
        lines.append("file '%s'" % path.replace("'", "'\\''"))
        if i + 1 < len(chunks):
            start, _, video_end = probed[i]
            next_start, next_first, _ = probed[i + 1]
            duration = (video_end - start) - (next_first - next_start)
            lines.append("duration %.6f" % duration)
    return "\n".join(lines) + "\n"


def join(chunks, output, list_path):
    """Writes `output` from `chunks` with `ffmpeg -f concat -c copy` through `list_path`, which
    is removed afterwards, whether the join succeeds or not."""
    try:
        with open(list_path, "w") as f:
            f.write(concat_list(chunks))
        subprocess.run(
            ["ffmpeg", "-hide_banner", "-nostdin", "-v", "error", "-y", "-f", "concat", "-safe",
             "0", "-i", list_path, "-map", "0", "-c", "copy", output],
            check=True)
    finally:
        if os.path.exists(list_path):
            os.remove(list_path)


if __name__ == "__main__":
    if len(sys.argv) < 4:
        sys.exit("usage: join.py OUTPUT CHUNK1 CHUNK2 [...]")
    join(sys.argv[2:], sys.argv[1], sys.argv[1] + ".ffconcat")
