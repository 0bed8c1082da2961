#!/usr/bin/env python3
"""Hand-drawn depth map for street.mp4 at 2.0 s: the walls and pillars that stand below the
horizon, so the wet ground stops at their feet. Ground and sky stay 0 (unknown: taken for ground).

Writes a 16-bit big-endian PGM (millimetres of camera z) to stdout; convert it with
`ffmpeg -i - -pix_fmt gray16be street-depth.png`. The outlines were read off the frame at 2 s;
the clip pans 9 px/s, so the map fits that frame only.
"""
import sys

WIDTH, HEIGHT = 640, 360
LEFT_WALL_MM = 5000
RIGHT_WALL_MM = 4000


def depth_mm(x, row):
    # Left: the near facade (its foot falls from row 257 to 235 across x 0..88), then the
    # second house (foot at row 220) up to the street's end at x 180.
    if x < 88 and row <= 257 - 22 * x / 88:
        return LEFT_WALL_MM
    if 88 <= x < 180 and row <= 220:
        return LEFT_WALL_MM
    # Right: the low block (foot at 245), the slim pillar (252), the gap before the big
    # low wall (240), and the big low wall whose foot runs from (478, 300) to (640, 347).
    if x >= 365:
        if x < 418:
            foot = 245
        elif x < 460:
            foot = 252
        elif x < 478:
            foot = 240
        else:
            foot = 300 + (x - 478) * 47 / 162
        if row <= foot:
            return RIGHT_WALL_MM
    return 0


def main():
    out = sys.stdout.buffer
    out.write(b"P5\n%d %d\n65535\n" % (WIDTH, HEIGHT))
    for row in range(HEIGHT):
        out.write(b"".join(depth_mm(x, row).to_bytes(2, "big") for x in range(WIDTH)))


if __name__ == "__main__":
    main()
