#!/usr/bin/env python3
"""Converts this folder's Redwood-format trajectory (trajectory.log: per frame a line
"id id frame" and a 4x4 camera-to-world matrix) into the TUM RGB-D layout lightskin reads:
rgb.txt, depth.txt (timestamp = frame / 30 s, ICL-NUIM renders at 30 fps) and groundtruth.txt
("timestamp tx ty tz qx qy qz qw", camera to world). Run from this folder; pure Python."""
import math

def quaternion(r):  # rotation matrix (rows) -> (x, y, z, w), Shepperd's method
    t = r[0][0] + r[1][1] + r[2][2]
    if t > 0:
        s = math.sqrt(t + 1.0) * 2
        return ((r[2][1] - r[1][2]) / s, (r[0][2] - r[2][0]) / s, (r[1][0] - r[0][1]) / s, 0.25 * s)
    i = max(range(3), key=lambda k: r[k][k])
    j, k = (i + 1) % 3, (i + 2) % 3
    s = math.sqrt(1.0 + r[i][i] - r[j][j] - r[k][k]) * 2
    q = [0.0, 0.0, 0.0, (r[k][j] - r[j][k]) / s]
    q[i] = 0.25 * s
    q[j] = (r[j][i] + r[i][j]) / s
    q[k] = (r[k][i] + r[i][k]) / s
    return tuple(q)

lines = [l for l in open("trajectory.log").read().splitlines() if l.strip()]
header = "# converted from trajectory.log by redwood_log_to_tum.py\n# timestamp {}\n"
with open("rgb.txt", "w") as rgb, open("depth.txt", "w") as depth, open("groundtruth.txt", "w") as gt:
    rgb.write(header.format("filename"))
    depth.write(header.format("filename"))
    gt.write(header.format("tx ty tz qx qy qz qw"))
    for n in range(len(lines) // 5):
        frame = int(lines[5 * n].split()[2]) - 1  # Redwood frame ids are 1-based here (0 0 1, 1 1 2, ...)
        m = [[float(v) for v in lines[5 * n + 1 + r].split()] for r in range(4)]
        t = frame / 30.0
        rgb.write("%.6f color/%05d.jpg\n" % (t, frame))
        depth.write("%.6f depth/%05d.png\n" % (t, frame))
        q = quaternion(m)
        gt.write("%.6f %.12f %.12f %.12f %.12f %.12f %.12f %.12f\n" % (t, m[0][3], m[1][3], m[2][3], *q))
