"""A short backlit clip from an equirectangular HDR panorama: a 60° pinhole view, pitched 8°
above the sun, panning slowly past it; exposed once for a median luminance of 0.18, clipped at
1.0 and written as sRGB 8-bit RGB frames on stdout (a display-referred video, as a camera makes).

Usage (see README.md): python3 make_pano_clip.py PANO.raw AZIMUTH_DEG ELEVATION_DEG | ffmpeg ...
PANO.raw: the panorama as 1024×512 planar float32 G, B, R (ffmpeg's gbrpf32le)."""
import sys, numpy as np
raw_path, az_sun, el_sun = sys.argv[1], float(sys.argv[2]), float(sys.argv[3])
W, H, FPS, SECS = 640, 360, 25, 4
a = np.fromfile(raw_path, dtype=np.float32).reshape(3, 512, 1024)
rgb = np.stack([a[2], a[0], a[1]], axis=-1)  # gbr planes → rgb
f = (W / 2) / np.tan(np.radians(30))
xs, ys = np.meshgrid(np.arange(W) + 0.5 - W / 2, np.arange(H) + 0.5 - H / 2)
def view(yaw, pitch):
    # camera: x right, y down, z forward; yaw about the vertical, pitch up
    d = np.stack([xs / f, -ys / f, np.ones_like(xs)], -1)
    d /= np.linalg.norm(d, axis=-1, keepdims=True)
    cp, sp = np.cos(np.radians(pitch)), np.sin(np.radians(pitch))
    y_up = d[..., 1] * cp + d[..., 2] * sp
    z_f = -d[..., 1] * sp + d[..., 2] * cp
    az = np.radians(yaw) + np.arctan2(d[..., 0], z_f)
    el = np.arcsin(np.clip(y_up, -1, 1))
    col = (np.degrees(az) % 360) / 360 * 1024 - 0.5
    row = (90 - np.degrees(el)) / 180 * 512 - 0.5
    c0 = np.floor(col).astype(int); r0 = np.clip(np.floor(row).astype(int), 0, 510)
    fc = (col - c0)[..., None]; fr = np.clip(row - r0, 0, 1)[..., None]
    c0 %= 1024; c1 = (c0 + 1) % 1024
    return ((rgb[r0, c0] * (1 - fc) + rgb[r0, c1] * fc) * (1 - fr)
            + (rgb[r0 + 1, c0] * (1 - fc) + rgb[r0 + 1, c1] * fc) * fr)
exposure = None
out = sys.stdout.buffer
for i in range(FPS * SECS):
    yaw = az_sun - 18 + 6 * i / (FPS * SECS)   # the sun right of centre, drifting left
    img = view(yaw, el_sun + 8)
    if exposure is None:
        lum = img @ np.array([0.2126, 0.7152, 0.0722])
        exposure = 0.18 / np.median(lum)
    v = np.clip(img * exposure, 0, 1)
    s = np.where(v <= 0.0031308, 12.92 * v, 1.055 * v ** (1 / 2.4) - 0.055)
    out.write((s * 255 + 0.5).astype(np.uint8).tobytes())
