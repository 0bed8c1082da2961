"""A camera turning over one photo: the photo is taken as a 60° pinhole view, and each frame is
the view of that camera turned by a pan of 3°/s from −6° (with 0.3° of shake at 1.5 Hz, and 0.25°
of tilt shake at 1.1 Hz), cropped to 480×270 at the photo's focal length (46.8° across): for a
turn about the camera's centre the homography K R K⁻¹ is exact, whatever the scene's depth.
100 frames at 25 fps of RGB24 on stdout.

Usage: python3 make_turn_clip.py PHOTO.rgb | ffmpeg -f rawvideo -pix_fmt rgb24 -s 480x270 -r 25 \\
    -i - -c:v libx264 -crf 16 -pix_fmt yuv420p turn.mp4
PHOTO.rgb: 640×360 RGB24, e.g. `ffmpeg -i street.mp4 -frames:v 1 -f rawvideo -pix_fmt rgb24
street0.rgb`."""
import sys, numpy as np
W, H = 640, 360
src = np.fromfile(sys.argv[1], dtype=np.uint8).reshape(H, W, 3).astype(np.float32)
f = (W / 2) / np.tan(np.radians(30))
w, h, fps, n = 480, 270, 25, 100
xs, ys = np.meshgrid(np.arange(w) + 0.5 - w / 2, np.arange(h) + 0.5 - h / 2)
out = sys.stdout.buffer
for i in range(n):
    t = i / fps
    yaw = np.radians(-6 + 3.0 * t + 0.3 * np.sin(2 * np.pi * 1.5 * t))
    pitch = np.radians(0.25 * np.sin(2 * np.pi * 1.1 * t))
    d = np.stack([xs / f, ys / f, np.ones_like(xs)], -1)
    # This frame's camera → the photo's: about y by the pan (right positive), then about x.
    cy, sy = np.cos(yaw), np.sin(yaw)
    cp, sp = np.cos(pitch), np.sin(pitch)
    x1 = cy * d[..., 0] + sy * d[..., 2]
    z1 = -sy * d[..., 0] + cy * d[..., 2]
    y2 = cp * d[..., 1] - sp * z1
    z2 = sp * d[..., 1] + cp * z1
    u = f * x1 / z2 + W / 2 - 0.5
    v = f * y2 / z2 + H / 2 - 0.5
    u0 = np.clip(np.floor(u).astype(int), 0, W - 2)
    v0 = np.clip(np.floor(v).astype(int), 0, H - 2)
    fu = np.clip(u - u0, 0, 1)[..., None]
    fv = np.clip(v - v0, 0, 1)[..., None]
    img = ((src[v0, u0] * (1 - fu) + src[v0, u0 + 1] * fu) * (1 - fv)
           + (src[v0 + 1, u0] * (1 - fu) + src[v0 + 1, u0 + 1] * fu) * fv)
    out.write(np.clip(img + 0.5, 0, 255).astype(np.uint8).tobytes())
