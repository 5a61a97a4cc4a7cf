#!/usr/bin/env python3
"""Checks the viewer's screenshot of the pyramid scene (standard library only).

The expected picture is computed, not stored: the camera of the scene is read from the scene
table in examples/viewer.rs, the pyramid's cubes are where impact3d::scenes::pyramid puts them
(base 10, 1 m cubes, 1.05 m apart in a row, row r at height 0.5 + r), and each point is
projected with Bevy's default perspective (vertical field of view pi/4). Then:

- the image is 1280 x 720 and not blank (luminance spread);
- the centre of the front face of every cube is body-coloured (orange: red well above blue);
- points on the ground in front of the pyramid are ground-coloured (the green checker);
- points above the pyramid are sky-coloured (the blue clear colour).

Each sample is the per-channel median of a 5 x 5 patch, so a gizmo line through it does not
decide the colour. Usage: check_screenshot.py SCREENSHOT.png VIEWER_SOURCE.rs
"""

import math
import re
import struct
import sys
import zlib

WIDTH, HEIGHT = 1280, 720
FOV = math.pi / 4


def read_png(path):
    """Width, height and rows of (r, g, b) tuples of an 8-bit RGB or RGBA PNG."""
    data = open(path, "rb").read()
    if data[:8] != b"\x89PNG\r\n\x1a\n":
        raise ValueError("not a PNG")
    pos, idat, header = 8, b"", None
    while pos < len(data):
        (length,) = struct.unpack(">I", data[pos : pos + 4])
        kind = data[pos + 4 : pos + 8]
        body = data[pos + 8 : pos + 8 + length]
        pos += 12 + length
        if kind == b"IHDR":
            header = struct.unpack(">IIBBBBB", body)
        elif kind == b"IDAT":
            idat += body
    width, height, depth, color, _, _, interlace = header
    if depth != 8 or color not in (2, 6) or interlace:
        raise ValueError(f"unsupported PNG: depth {depth}, colour type {color}")
    channels = 3 if color == 2 else 4
    raw = zlib.decompress(idat)
    stride = width * channels
    rows, prev, at = [], bytearray(stride), 0
    for _ in range(height):
        kind, line = raw[at], bytearray(raw[at + 1 : at + 1 + stride])
        at += 1 + stride
        for i in range(stride):
            a = line[i - channels] if i >= channels else 0
            b = prev[i]
            c = prev[i - channels] if i >= channels else 0
            if kind == 1:
                line[i] = (line[i] + a) & 255
            elif kind == 2:
                line[i] = (line[i] + b) & 255
            elif kind == 3:
                line[i] = (line[i] + (a + b) // 2) & 255
            elif kind == 4:
                p = a + b - c
                pa, pb, pc = abs(p - a), abs(p - b), abs(p - c)
                pred = a if pa <= pb and pa <= pc else (b if pb <= pc else c)
                line[i] = (line[i] + pred) & 255
        rows.append([tuple(line[k : k + 3]) for k in range(0, stride, channels)])
        prev = line
    return width, height, rows


def scene_view(source, name):
    """(focus, yaw, pitch, distance) of the named scene in the viewer's table."""
    text = open(source).read()
    at = text.index(f'name: "{name}"')
    m = re.search(
        r"view: view\(Vec3::new\(([-\d.]+), ([-\d.]+), ([-\d.]+)\), ([-\d.]+), ([-\d.]+), ([-\d.]+)\)",
        text[at:],
    )
    fx, fy, fz, yaw, pitch, distance = map(float, m.groups())
    return (fx, fy, fz), yaw, pitch, distance


def projector(focus, yaw, pitch, distance):
    """Maps a world point to pixel coordinates, as the viewer's orbit camera sees it."""
    cp, sp, cy, sy = math.cos(pitch), math.sin(pitch), math.cos(yaw), math.sin(yaw)
    eye = [focus[i] + distance * d for i, d in enumerate((cp * sy, sp, cp * cy))]
    sub = lambda a, b: [a[i] - b[i] for i in range(3)]
    dot = lambda a, b: sum(a[i] * b[i] for i in range(3))
    cross = lambda a, b: [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
    norm = lambda a: [x / math.sqrt(dot(a, a)) for x in a]
    forward = norm(sub(focus, eye))
    right = norm(cross(forward, [0.0, 1.0, 0.0]))
    up = cross(right, forward)
    t = math.tan(FOV / 2)
    aspect = WIDTH / HEIGHT

    def project(p):
        d = sub(p, eye)
        z = dot(d, forward)
        x = dot(d, right) / (z * t * aspect)
        y = dot(d, up) / (z * t)
        return (x + 1) / 2 * WIDTH, (1 - y) / 2 * HEIGHT

    return project


def patch(rows, u, v):
    """Per-channel median colour of the 5 x 5 patch around pixel (u, v)."""
    u, v = int(round(u)), int(round(v))
    pixels = [rows[y][x] for y in range(v - 2, v + 3) for x in range(u - 2, u + 3)]
    return tuple(sorted(p[c] for p in pixels)[len(pixels) // 2] for c in range(3))


def is_body(c):
    return c[0] > c[2] + 60 and c[0] > c[1] + 20


def is_ground(c):
    return c[1] > c[0] + 5 and c[1] > c[2] + 5


def is_sky(c):
    return c[2] > c[0] + 30 and c[2] > c[1]


def main():
    png, source = sys.argv[1], sys.argv[2]
    width, height, rows = read_png(png)
    failures = []
    if (width, height) != (WIDTH, HEIGHT):
        sys.exit(f"FAIL: screenshot is {width}x{height}, expected {WIDTH}x{HEIGHT}")
    lum = [0.3 * p[0] + 0.59 * p[1] + 0.11 * p[2] for r in rows[::8] for p in r[::8]]
    mean = sum(lum) / len(lum)
    spread = math.sqrt(sum((x - mean) ** 2 for x in lum) / len(lum))
    if spread < 10:
        sys.exit(f"FAIL: blank picture (luminance spread {spread:.1f})")

    project = projector(*scene_view(source, "pyramid, base 10"))
    checks = []
    base = 10
    for row in range(base):
        count = base - row
        for i in range(count):
            x = (i - (count - 1) * 0.5) * 1.05
            checks.append(("body", f"cube row {row} #{i}", (x, 0.5 + row, 0.5), is_body))
    for p in [(1.0, 0.0, 5.0), (-3.0, 0.0, 3.0), (3.0, 0.0, 3.0), (-1.0, 0.0, 7.0)]:
        checks.append(("ground", f"ground {p}", p, is_ground))
    for p in [(-8.0, 10.0, 0.0), (8.0, 9.0, 0.0), (-12.0, 9.0, 0.0)]:
        checks.append(("sky", f"sky {p}", p, is_sky))
    counts = {}
    for kind, label, point, test in checks:
        u, v = project(point)
        if not (2 <= u < WIDTH - 2 and 2 <= v < HEIGHT - 2):
            failures.append(f"{label} projects off screen at ({u:.0f}, {v:.0f})")
            continue
        c = patch(rows, u, v)
        ok = test(c)
        counts[kind] = counts.get(kind, 0) + ok
        if not ok:
            failures.append(f"{label} at pixel ({u:.0f}, {v:.0f}) has colour {c}, not {kind}")
    print(f"screenshot {png}: luminance spread {spread:.1f}, passed {counts}")
    if failures:
        print("FAIL:\n  " + "\n  ".join(failures))
        sys.exit(1)
    print("screenshot check passed")


if __name__ == "__main__":
    main()
