#!/usr/bin/env python3
"""Where the brute force's speckle pixels on real depth come from (TUM fr3): reads the files
`lightskin-tools bench-realdepth --maps` writes per case and frame (STEM = <out>/images/<case>_frame<N>):

    STEM_vals.csv               the depth VALs as the techniques got them (culled ones: area 0)
    STEM_gbuffer_position.f32   G-buffer world positions, float32 RGBA, rows top to bottom (w = covered)
    STEM_gbuffer_normal.f32     G-buffer world normals, float32 RGBA
    STEM_bruteforce_Y.f32       the brute force's indirect luminance, float32
and the case's <case>_speckle_pixels.csv. For every brute-force speckle pixel it recomputes the brute
force in double precision (eq. 3, 4 per VAL, point model, no occlusion: what bruteforce_gather.frag
sums; the albedo is the scene's bunny's) and prints: the GL value against the recomputation, how many
VALs make 80 % of the light and where they come from (depth-pixel rows, distance, incidence: the share
with cos(theta_i) < 0.3), and the pixel's value over the median of its 5x5 window (a) as rendered,
(b) with the pixel's normal replaced by its window's mean normal, (c) with the floor continued toward
the camera beyond the depth image's last VAL row (--extend K: copies of the last row's VALs shifted
K times by the step between the last two rows; a what-if, not a light model).

    python3 bench/plots/realdepth_val_analysis.py decompose STEM SPECKLE_CSV [--extend 15] [--width 640]
    python3 bench/plots/realdepth_val_analysis.py normals NEW_STEM OLD_STEM [--columns 0,400] [--seeds 3]
    python3 bench/plots/realdepth_val_analysis.py truth NEW_TRUTH_CSV OLD_TRUTH_CSV
    python3 bench/plots/realdepth_val_analysis.py loop-subdivide IN.ply OUT.ply [--levels 2]

normals (why total light fell with the loader's smooth normals): two runs of the same case and frame whose
only difference is the mesh's normals (NEW_STEM, OLD_STEM); per covered pixel in the image columns [a, b) (one
object) the brute force in double (as decompose) with the new normals, the old ones, and the new ones turned by
the measured old-new angles, shuffled over the pixels, about random axes (scatter without the old normals' own
pattern; --seeds draws); totals, and per incidence class c = cos(new normal, the pixel's vector irradiance: the sum of
the VALs' per-VAL irradiance direction, weights as eq. 3 without cos_i), c < 0 = the light comes from behind the
normal and reaches the receiver only near its horizon. truth: the --truth CSVs of two such runs (the same pixels),
the brute force, LightSkin and the Embree truth with visibility, summed, old against new.

loop-subdivide writes Loop's smooth subdivision of an ASCII PLY triangle mesh (a finer mesh of the same
shape, for checking whether a light feature is the coarse mesh's). Exit status: 0 done, 2 bad input
(the message names the file and the cause).
"""

import argparse
import csv
import sys

import numpy as np

LUMINANCE = np.array([0.2126, 0.7152, 0.0722])
ALBEDO = np.array([0.7, 0.68, 0.64])  # recordings/scenes/on_real_surface.json, the bunny


def fail(path, cause):
    print(f"realdepth_val_analysis: {path}: {cause}", file=sys.stderr)
    sys.exit(2)


def load_image(path, width, channels):
    try:
        data = np.fromfile(path, np.float32)
    except OSError as e:
        fail(path, f"cannot read ({e.strerror})")
    if data.size == 0 or data.size % (width * channels):
        fail(path, f"{data.size} floats is not a whole number of {width}-pixel rows of {channels} channels")
    return data.reshape(-1, width, channels) if channels > 1 else data.reshape(-1, width)


def load_vals(path):
    try:
        v = np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2)
    except (OSError, ValueError) as e:
        fail(path, f"cannot read the VAL table ({e})")
    if v.shape[1] != 12:
        fail(path, f"expected 12 columns (u,v,x,y,z,normal_x..z,area,flux_r..b), found {v.shape[1]}")
    return v


class Vals:
    def __init__(self, table):
        self.pixel = table[:, 0:2].astype(int)
        self.position = table[:, 2:5]
        self.normal = table[:, 5:8]
        self.area = table[:, 8]
        self.flux = (table[:, 9:12] * ALBEDO) @ LUMINANCE  # reflected luminance per unit irradiance

    def extended(self, k):
        """The last VAL row continued k rows toward the camera (same normal, area, flux)."""
        rows = sorted(set(self.pixel[self.area > 0, 1]))
        if k <= 0 or len(rows) < 2:
            return self
        last, before = rows[-1], rows[-2]
        previous = {u: j for j, (u, v) in enumerate(self.pixel) if v == before and self.area[j] > 0}
        extra = []
        for j, (u, v) in enumerate(self.pixel):
            if v == last and self.area[j] > 0 and u in previous:
                step = self.position[j] - self.position[previous[u]]
                extra += [(j, self.position[j] + i * step) for i in range(1, k + 1)]
        out = Vals(np.zeros((0, 12)))
        index = np.array([j for j, _ in extra], dtype=int)
        out.pixel = np.vstack([self.pixel, self.pixel[index]])
        out.position = np.vstack([self.position] + [p[None] for _, p in extra])
        out.normal = np.vstack([self.normal, self.normal[index]])
        out.area = np.concatenate([self.area, self.area[index]])
        out.flux = np.concatenate([self.flux, self.flux[index]])
        out.added = len(extra)
        return out

    def terms(self, x, n):
        """Per VAL: the brute force's luminance term, distance, cos(theta_i)."""
        n = n / np.linalg.norm(n)
        offset = self.position - x
        d2 = (offset ** 2).sum(1)
        r2 = np.where(self.area > 0, self.area / np.pi, 0.0)
        t = offset / np.sqrt(np.maximum(d2 + 1e-12 * r2, 1e-36))[:, None]
        cos_i = np.maximum(t @ n, 0.0)
        cos_j = np.maximum(-(self.normal * t).sum(1), 0.0)
        term = np.where(self.area > 0, self.flux * cos_j / np.maximum(r2 + d2, 1e-36) / np.pi * cos_i / np.pi, 0.0)
        return term, np.sqrt(d2), cos_i


def decompose(args):
    position = load_image(args.stem + "_gbuffer_position.f32", args.width, 4)
    normal = load_image(args.stem + "_gbuffer_normal.f32", args.width, 4)
    brute = load_image(args.stem + "_bruteforce_Y.f32", args.width, 1)
    vals = Vals(load_vals(args.stem + "_vals.csv"))
    longer = vals.extended(args.extend)
    try:
        rows = [r for r in csv.DictReader(open(args.speckle_csv)) if r["technique"] == "brute-force"]
    except (OSError, KeyError) as e:
        fail(args.speckle_csv, f"cannot read the speckle pixels ({e})")
    print(f"{int((vals.area > 0).sum())} VALs ({int((vals.area <= 0).sum())} culled); "
          f"--extend {args.extend}: {getattr(longer, 'added', 0)} VALs added")

    def window(u, v, source, own_normal=None):
        out = np.full((5, 5), np.nan)
        for dv in range(-2, 3):
            for du in range(-2, 3):
                if position[v + dv, u + du, 3] > 0:
                    n = normal[v + dv, u + du, :3].astype(float)
                    if own_normal is not None and dv == 0 and du == 0:
                        n = own_normal
                    out[dv + 2, du + 2] = source.terms(position[v + dv, u + du, :3].astype(float), n)[0].sum()
        return out[2, 2] / np.nanmedian(out)

    for r in rows:
        u, v = int(r["u"]), int(r["v"])
        if not (2 <= v < position.shape[0] - 2 and 2 <= u < args.width - 2) or position[v, u, 3] <= 0:
            fail(args.speckle_csv, f"pixel ({u}, {v}) is not covered in {args.stem}_gbuffer_position.f32")
        x, n = position[v, u, :3].astype(float), normal[v, u, :3].astype(float)
        term, distance, cos_i = vals.terms(x, n)
        e = term.sum()
        order = np.argsort(-term)
        top = order[: np.searchsorted(np.cumsum(term[order]), 0.8 * e) + 1]
        covered = position[v - 2:v + 3, u - 2:u + 3, 3].reshape(-1) > 0
        mean_normal = normal[v - 2:v + 3, u - 2:u + 3, :3].reshape(-1, 3)[covered].mean(0)
        print(f"({u},{v}) GL {brute[v, u]:.5g} recomputed {e:.5g}; 80 % from {len(top)} VALs, rows "
              f"{vals.pixel[top, 1].min()}-{vals.pixel[top, 1].max()}, {distance[top].min() * 100:.0f}-"
              f"{distance[top].max() * 100:.0f} cm; cos(theta_i) < 0.3: {term[cos_i < 0.3].sum() / e * 100:.0f} %; "
              f"Y / median: {window(u, v, vals):.2f} as rendered, {window(u, v, vals, mean_normal):.2f} with the "
              f"window's mean normal, {window(u, v, longer):.2f} with the floor extended")


def irradiance(vals, x, normals):
    """The brute force's luminance (Vals.terms summed) at receivers x (n x 3) for each normal field in `normals`
    (each n x 3 unit), and the receivers' vector irradiance (the same weights without cos_i, times the direction)."""
    r2 = np.where(vals.area > 0, vals.area / np.pi, 0.0)
    out = [np.zeros(len(x)) for _ in normals]
    vector = np.zeros((len(x), 3))
    for s in range(0, len(x), 256):
        offset = vals.position[None] - x[s:s + 256, None]
        d2 = (offset ** 2).sum(2)
        t = offset / np.sqrt(np.maximum(d2 + 1e-12 * r2[None], 1e-36))[..., None]
        cos_j = np.maximum(-(vals.normal[None] * t).sum(2), 0.0)
        w = np.where(vals.area[None] > 0, vals.flux[None] * cos_j / np.maximum(r2[None] + d2, 1e-36) / np.pi / np.pi, 0.0)
        vector[s:s + 256] = (w[..., None] * t).sum(1)
        for k, n in enumerate(normals):
            out[k][s:s + 256] = (w * np.maximum((t * n[s:s + 256, None]).sum(2), 0.0)).sum(1)
    return out, vector


def unit_rows(a):
    return a / np.linalg.norm(a, axis=1, keepdims=True)


def normals(args):
    a, b = (int(c) for c in args.columns.split(","))
    position = load_image(args.new + "_gbuffer_position.f32", args.width, 4)
    new_normal = load_image(args.new + "_gbuffer_normal.f32", args.width, 4)
    old_normal = load_image(args.old + "_gbuffer_normal.f32", args.width, 4)
    if not np.array_equal(position, load_image(args.old + "_gbuffer_position.f32", args.width, 4)):
        fail(args.old + "_gbuffer_position.f32", "not the G-buffer positions of " + args.new + ": not the same case")
    table = load_vals(args.new + "_vals.csv")
    old_table = load_vals(args.old + "_vals.csv")
    order = lambda t: t[np.lexsort((t[:, 0], t[:, 1]))]  # the GPU appends VALs in any order
    if table.shape != old_table.shape or not np.array_equal(order(table), order(old_table)):
        fail(args.old + "_vals.csv", "not the VALs of " + args.new + ": not the same case and frame")
    vals = Vals(table)
    v, u = np.nonzero(position[..., 3] > 0)
    keep = (u >= a) & (u < b)
    v, u = v[keep], u[keep]
    if len(u) == 0:
        fail(args.new + "_gbuffer_position.f32", f"no covered pixel in columns [{a}, {b})")
    x = position[v, u, :3].astype(float)
    n_new, n_old = unit_rows(new_normal[v, u, :3].astype(float)), unit_rows(old_normal[v, u, :3].astype(float))
    angle = np.arccos(np.clip((n_new * n_old).sum(1), -1.0, 1.0))
    rng = np.random.default_rng(1)
    turned = []
    for _ in range(args.seeds):
        theta = rng.permutation(angle)
        axis = unit_rows(np.cross(n_new, rng.normal(size=n_new.shape)))
        turned.append(unit_rows(n_new * np.cos(theta)[:, None] + axis * np.sin(theta)[:, None]))
    (e_new, e_old, *e_turned), vector = irradiance(vals, x, [n_new, n_old] + turned)
    print(f"{len(u)} pixels; old-new normal angle median {np.degrees(np.median(angle)):.1f}, 90th percentile "
          f"{np.degrees(np.percentile(angle, 90)):.1f} degrees; mean old - new normal "
          f"({', '.join(f'{c:.3f}' for c in (n_old - n_new).mean(0))})")
    change = lambda e, m: e[m].sum() / e_new[m].sum() - 1.0 if e_new[m].sum() > 0 else float("nan")
    everything = np.ones(len(u), bool)
    print(f"total: new {e_new.sum():.6g}, old {e_old.sum():.6g} ({change(e_old, everything):+.1%}), turned "
          + ", ".join(f"{e.sum():.6g} ({change(e, everything):+.1%})" for e in e_turned))
    c = (vector * n_new).sum(1) / np.maximum(np.linalg.norm(vector, axis=1), 1e-300)
    for lo, hi, name in ((-2.0, 0.0, "c < 0"), (0.0, 0.3, "0 <= c < 0.3"), (0.3, 0.7, "0.3 <= c < 0.7"), (0.7, 2.0, "c >= 0.7")):
        m = (c >= lo) & (c < hi)
        if m.any():
            print(f"class {name}: {m.sum()} pixels, new {e_new[m].sum():.6g} ({e_new[m].sum() / max(e_new.sum(), 1e-300):.0%} "
                  f"of the total), old {change(e_old, m):+.1%} (change {e_old[m].sum() - e_new[m].sum():+.6g}), turned "
                  + ", ".join(f"{change(e, m):+.1%}" for e in e_turned))


def truth(args):
    def load(path):
        try:
            rows = list(csv.DictReader(open(path)))
            return {k: np.array([float(r[k]) for r in rows]) for k in ("u", "v", "normal_x", "normal_y", "normal_z",
                    "lightskin_Y", "bruteforce_Y", "truth_Y", "truth_unoccluded_Y")}
        except (OSError, KeyError, ValueError) as e:
            fail(path, f"cannot read the truth table ({e})")
    new, old = load(args.new), load(args.old)
    if not (np.array_equal(new["u"], old["u"]) and np.array_equal(new["v"], old["v"])) or len(new["u"]) == 0:
        fail(args.old, "not the pixels of " + args.new)
    total = {f"{k} {name}": t[k].sum() for name, t in (("new", new), ("old", old))
             for k in ("bruteforce_Y", "lightskin_Y", "truth_Y", "truth_unoccluded_Y")}
    print(f"{len(new['u'])} pixels")
    for k in ("truth_Y", "truth_unoccluded_Y", "bruteforce_Y", "lightskin_Y"):
        print(f"{k}: new {total[k + ' new']:.6g}, old {total[k + ' old']:.6g}, old / new "
              f"{total[k + ' old'] / total[k + ' new']:.3f}")
    for k in ("bruteforce_Y", "lightskin_Y"):
        print(f"{k} / truth_Y with the new normals: new {total[k + ' new'] / total['truth_Y new']:.3f}, old "
              f"{total[k + ' old'] / total['truth_Y new']:.3f}; each with its own normals: new "
              f"{total[k + ' new'] / total['truth_Y new']:.3f}, old {total[k + ' old'] / total['truth_Y old']:.3f}")


def loop_subdivide(args):
    try:
        lines = open(args.input).read().split("\n")
        i, vertices, faces = 0, 0, 0
        while lines[i].strip() != "end_header":
            if lines[i].startswith("element vertex"):
                vertices = int(lines[i].split()[2])
            if lines[i].startswith("element face"):
                faces = int(lines[i].split()[2])
            i += 1
        i += 1
        points = np.array([[float(t) for t in lines[i + k].split()[:3]] for k in range(vertices)])
        i += vertices
        triangles = np.array([[int(t) for t in lines[i + k].split()[1:4]] for k in range(faces)])
    except (OSError, IndexError, ValueError) as e:
        fail(args.input, f"not an ASCII PLY triangle mesh ({e})")
    for _ in range(args.levels):
        n = len(points)
        opposite = {}
        for f in triangles:
            for a in range(3):
                opposite.setdefault(tuple(sorted((f[a], f[(a + 1) % 3]))), []).append(f[(a + 2) % 3])
        neighbours = [set() for _ in range(n)]
        for a, b in opposite:
            neighbours[a].add(b)
            neighbours[b].add(a)
        boundary = {v for e, o in opposite.items() if len(o) != 2 for v in e}
        edge_point, new = {}, []
        for e, o in opposite.items():
            a, b = e
            p = 0.375 * (points[a] + points[b]) + 0.125 * (points[o[0]] + points[o[1]]) if len(o) == 2 \
                else 0.5 * (points[a] + points[b])
            edge_point[e] = n + len(new)
            new.append(p)
        moved = points.copy()
        for v in range(n):
            k = len(neighbours[v])
            if k == 0:
                continue
            if v in boundary:
                ends = [w for w in neighbours[v] if len(opposite[tuple(sorted((v, w)))]) != 2]
                if len(ends) == 2:
                    moved[v] = 0.75 * points[v] + 0.125 * (points[ends[0]] + points[ends[1]])
                continue
            beta = (5.0 / 8.0 - (3.0 / 8.0 + 0.25 * np.cos(2.0 * np.pi / k)) ** 2) / k  # Loop's weights
            moved[v] = (1.0 - k * beta) * points[v] + beta * sum(points[w] for w in neighbours[v])
        points = np.vstack([moved, np.array(new)])
        finer = []
        for a, b, c in triangles:
            ab, bc, ca = (edge_point[tuple(sorted(e))] for e in ((a, b), (b, c), (c, a)))
            finer += [[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]
        triangles = np.array(finer)
    with open(args.output, "w") as out:
        out.write(f"ply\nformat ascii 1.0\nelement vertex {len(points)}\nproperty float x\nproperty float y\n"
                  f"property float z\nelement face {len(triangles)}\nproperty list uchar int vertex_indices\nend_header\n")
        out.writelines(f"{p[0]:.7f} {p[1]:.7f} {p[2]:.7f}\n" for p in points)
        out.writelines(f"3 {f[0]} {f[1]} {f[2]}\n" for f in triangles)
    print(f"{args.output}: {len(points)} vertices, {len(triangles)} triangles")


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = parser.add_subparsers(dest="command", required=True)
    d = sub.add_parser("decompose")
    d.add_argument("stem")
    d.add_argument("speckle_csv")
    d.add_argument("--extend", type=int, default=15)
    d.add_argument("--width", type=int, default=640)
    n = sub.add_parser("normals")
    n.add_argument("new")
    n.add_argument("old")
    n.add_argument("--columns", default="0,100000")
    n.add_argument("--seeds", type=int, default=3)
    n.add_argument("--width", type=int, default=640)
    t = sub.add_parser("truth")
    t.add_argument("new")
    t.add_argument("old")
    s = sub.add_parser("loop-subdivide")
    s.add_argument("input")
    s.add_argument("output")
    s.add_argument("--levels", type=int, default=2)
    args = parser.parse_args()
    {"decompose": decompose, "normals": normals, "truth": truth, "loop-subdivide": loop_subdivide}[args.command](args)


if __name__ == "__main__":
    main()
