#!/usr/bin/env python3
"""bench/plots/realdepth_val_analysis.py on inputs whose answers are known in closed form: the brute
force of one VAL at one receiver (eq. 3, 4 written out here), the floor extension's count, the totals of
two normal fields and the incidence class (normals), the truth table's sums (truth), Loop's weights on a
tetrahedron, and bad input (exit 2 naming the file)."""
import math
import os
import subprocess
import sys
import tempfile
import unittest

import numpy as np

SCRIPT = os.path.join(os.path.dirname(__file__), "..", "..", "bench", "plots", "realdepth_val_analysis.py")
WIDTH = 8


def run(*args):
    return subprocess.run([sys.executable, SCRIPT, *args], capture_output=True, text=True)


class Decompose(unittest.TestCase):
    def setUp(self):
        self.dir = tempfile.TemporaryDirectory()
        self.stem = os.path.join(self.dir.name, "case_frame0")
        # An 8x8 G-buffer: the plane z = 0, 1 cm per pixel, normals +z, all covered.
        position = np.zeros((WIDTH, WIDTH, 4), np.float32)
        normal = np.zeros((WIDTH, WIDTH, 4), np.float32)
        for v in range(WIDTH):
            for u in range(WIDTH):
                position[v, u] = (0.01 * u, 0.01 * v, 0.0, 1.0)
                normal[v, u] = (0.0, 0.0, 1.0, 0.0)
        position.tofile(self.stem + "_gbuffer_position.f32")
        normal.tofile(self.stem + "_gbuffer_normal.f32")
        np.zeros((WIDTH, WIDTH), np.float32).tofile(self.stem + "_bruteforce_Y.f32")
        # VALs: one 20 cm above (0.05, 0.02) facing down and tilted; two rows (v = 0, 4) of two for
        # the extension (zero flux: they light nothing); a culled one (area 0) with a huge flux.
        self.light = np.array([0.05, 0.02, 0.2])
        self.light_normal = np.array([0.3, 0.0, -1.0]) / math.hypot(0.3, 1.0)
        rows = [(0, 0, *self.light, *self.light_normal, 1e-4, 1.0, 2.0, 3.0),
                (1, 0, 0, 0, 0.5, 0, 0, -1, 1e-4, 0, 0, 0), (5, 0, 0.1, 0, 0.5, 0, 0, -1, 1e-4, 0, 0, 0),
                (1, 4, 0, 0.1, 0.5, 0, 0, -1, 1e-4, 0, 0, 0), (5, 4, 0.1, 0.1, 0.5, 0, 0, -1, 1e-4, 0, 0, 0),
                (3, 3, 0.03, 0.03, 0.01, 0, 0, -1, 0.0, 1e6, 1e6, 1e6)]
        with open(self.stem + "_vals.csv", "w") as f:
            f.write("u,v,x,y,z,normal_x,normal_y,normal_z,area,flux_r,flux_g,flux_b\n")
            f.writelines(",".join(str(x) for x in r) + "\n" for r in rows)
        self.csv = os.path.join(self.dir.name, "speckle.csv")
        with open(self.csv, "w") as f:
            f.write("frame,u,v,technique,Y,median5x5\n0,3,4,brute-force,0,0\n0,3,4,lightskin,0,0\n")

    def tearDown(self):
        self.dir.cleanup()

    def test_recomputes_the_brute_force_and_extends_the_last_row(self):
        out = run("decompose", self.stem, self.csv, "--extend", "3", "--width", str(WIDTH))
        self.assertEqual(out.returncode, 0, out.stderr)
        # eq. 3, 4 for the receiver (0.03, 0.04, 0) with normal +z: E = Phi cos_i cos_j / (pi (r^2 + d^2)),
        # reflected luminance rho_Y E / pi, rho_Y and Phi_Y the luminance of the bunny's albedo times flux.
        x = np.array([0.03, 0.04, 0.0])
        d = self.light - x
        d2 = d @ d
        t = d / math.sqrt(d2)
        flux_y = np.array([1.0, 2.0, 3.0]) * np.array([0.7, 0.68, 0.64]) @ np.array([0.2126, 0.7152, 0.0722])
        expected = flux_y * t[2] * (-self.light_normal @ t) / (math.pi * (1e-4 / math.pi + d2)) / math.pi
        line = next(l for l in out.stdout.splitlines() if l.startswith("(3,4)"))
        recomputed = float(line.split("recomputed ")[1].split(";")[0])
        self.assertAlmostEqual(recomputed / expected, 1.0, delta=1e-4)  # printed to 5 significant digits
        self.assertIn("80 % from 1 VALs", line)
        self.assertIn("5 VALs (1 culled); --extend 3: 6 VALs added", out.stdout)  # 2 columns x 3 rows
        self.assertEqual(sum(l.startswith("(") for l in out.stdout.splitlines()), 1)  # brute force rows only

    def test_bad_input_names_the_file(self):
        os.remove(self.stem + "_vals.csv")
        out = run("decompose", self.stem, self.csv, "--width", str(WIDTH))
        self.assertEqual(out.returncode, 2)
        self.assertIn("case_frame0_vals.csv", out.stderr)
        out = run("decompose", self.stem, self.csv, "--width", "5")  # 64 pixels are not rows of 5
        self.assertEqual(out.returncode, 2)
        self.assertIn("_gbuffer_position.f32", out.stderr)


def brute_force(light, light_normal, area, flux_rgb, x, n):
    """eq. 3, 4 for one VAL at receiver x with normal n: reflected luminance rho_Y Phi_Y cos_i cos_j / (pi^2 (r^2 + d^2))."""
    d = light - x
    d2 = d @ d
    t = d / math.sqrt(d2)
    flux_y = np.array(flux_rgb) * np.array([0.7, 0.68, 0.64]) @ np.array([0.2126, 0.7152, 0.0722])
    return flux_y * max(t @ n, 0.0) * max(-light_normal @ t, 0.0) / (math.pi * (area / math.pi + d2)) / math.pi


class Normals(unittest.TestCase):
    """Two runs of one case that differ in the normals only: an 8x8 plane z = 0 (1 cm pixels) under one VAL
    20 cm above it, new normals +z, old ones turned by 30 degrees about x (toward the VAL's side, +y)."""

    def setUp(self):
        self.dir = tempfile.TemporaryDirectory()
        self.light = np.array([0.05, 0.3, 0.2])
        self.light_normal = np.array([0.0, -1.0, -1.0]) / math.sqrt(2.0)
        self.stems = {}
        a = math.radians(30.0)
        for name, n in (("new", (0.0, 0.0, 1.0)), ("old", (0.0, math.sin(a), math.cos(a))), ("same", (0.0, 0.0, 1.0))):
            stem = os.path.join(self.dir.name, name + "_frame0")
            position = np.zeros((WIDTH, WIDTH, 4), np.float32)
            normal = np.zeros((WIDTH, WIDTH, 4), np.float32)
            for v in range(WIDTH):
                for u in range(WIDTH):
                    position[v, u] = (0.01 * u, 0.01 * v, 0.0, 1.0)
                    normal[v, u] = (*n, 0.0)
            position.tofile(stem + "_gbuffer_position.f32")
            normal.tofile(stem + "_gbuffer_normal.f32")
            with open(stem + "_vals.csv", "w") as f:
                f.write("u,v,x,y,z,normal_x,normal_y,normal_z,area,flux_r,flux_g,flux_b\n")
                f.write(",".join(str(c) for c in (0, 0, *self.light, *self.light_normal, 1e-4, 1.0, 2.0, 3.0)) + "\n")
            self.stems[name] = stem

    def tearDown(self):
        self.dir.cleanup()

    def total(self, normal, columns=range(WIDTH)):
        return sum(brute_force(self.light, self.light_normal, 1e-4, (1.0, 2.0, 3.0), np.array([0.01 * u, 0.01 * v, 0.0]),
                               np.array(normal)) for v in range(WIDTH) for u in columns)

    def test_totals_of_both_normal_fields_and_the_incidence_class(self):
        out = run("normals", self.stems["new"], self.stems["old"], "--width", str(WIDTH), "--columns", "2,6")
        self.assertEqual(out.returncode, 0, out.stderr)
        line = next(l for l in out.stdout.splitlines() if l.startswith("total:"))
        new = float(line.split("new ")[1].split(",")[0])
        old = float(line.split("old ")[1].split(" ")[0])
        a = math.radians(30.0)
        self.assertAlmostEqual(new / self.total((0.0, 0.0, 1.0), range(2, 6)), 1.0, delta=1e-5)  # 6 digits printed
        self.assertAlmostEqual(old / self.total((0.0, math.sin(a), math.cos(a)), range(2, 6)), 1.0, delta=1e-5)
        self.assertIn("32 pixels; old-new normal angle median 30.0", out.stdout)
        # Incidence class: c = cos(+z, direction to the VAL) >= 0.3 for every pixel (the VAL is 20 cm up, <= 30 cm
        # away sideways), and at most 0.7 (it is at least 20 cm away in y) -> all 32 in one class.
        cosines = [0.2 / np.linalg.norm(self.light - np.array([0.01 * u, 0.01 * v, 0.0])) for v in range(WIDTH) for u in range(2, 6)]
        self.assertTrue(all(0.3 <= c < 0.7 for c in cosines))
        self.assertIn("class 0.3 <= c < 0.7: 32 pixels", out.stdout)

    def test_equal_normals_change_nothing(self):
        out = run("normals", self.stems["new"], self.stems["same"], "--width", str(WIDTH))
        self.assertEqual(out.returncode, 0, out.stderr)
        line = next(l for l in out.stdout.splitlines() if l.startswith("total:"))
        self.assertEqual(line.count("(+0.0%)"), 4)  # old and the three turned fields: angle 0

    def test_another_case_is_refused(self):
        with open(self.stems["same"] + "_vals.csv", "a") as f:
            f.write("1,0,0,0,0.5,0,0,-1,1e-4,0,0,0\n")
        out = run("normals", self.stems["new"], self.stems["same"], "--width", str(WIDTH))
        self.assertEqual(out.returncode, 2)
        self.assertIn("same_frame0_vals.csv", out.stderr)


class Truth(unittest.TestCase):
    def test_sums_and_ratios(self):
        header = "u,v,x,y,z,normal_x,normal_y,normal_z,lightskin_Y,bruteforce_Y,truth_Y,truth_unoccluded_Y,visible\n"
        with tempfile.TemporaryDirectory() as d:
            paths = [os.path.join(d, "new.csv"), os.path.join(d, "old.csv")]
            for path, rows in zip(paths, (("1,2,0,0,0,0,0,1,1.0,2.0,1.0,2.0,1", "3,4,0,0,0,0,0,1,1.0,2.0,3.0,2.0,1"),
                                          ("1,2,0,0,0,0,0,1,2.0,4.0,2.0,6.0,1", "3,4,0,0,0,0,0,1,2.0,4.0,3.0,2.0,1"))):
                with open(path, "w") as f:
                    f.write(header + "\n".join(rows) + "\n")
            out = run("truth", *paths)
            self.assertEqual(out.returncode, 0, out.stderr)
            self.assertIn("truth_Y: new 4, old 5, old / new 1.250", out.stdout)
            self.assertIn("bruteforce_Y: new 4, old 8, old / new 2.000", out.stdout)
            # brute force 4 and 8 against the truth 4 (new normals) and 5 (old)
            self.assertIn("bruteforce_Y / truth_Y with the new normals: new 1.000, old 2.000; each with its own "
                          "normals: new 1.000, old 1.600", out.stdout)
            with open(paths[1], "a") as f:
                f.write("5,6,0,0,0,0,0,1,1,1,1,1,1\n")
            out = run("truth", *paths)
            self.assertEqual(out.returncode, 2)
            self.assertIn("old.csv", out.stderr)


class LoopSubdivide(unittest.TestCase):
    def test_tetrahedron_one_level(self):
        p = np.array([[1, 1, 1], [1, -1, -1], [-1, 1, -1], [-1, -1, 1]], float)
        faces = [(0, 1, 2), (0, 3, 1), (0, 2, 3), (1, 3, 2)]
        with tempfile.TemporaryDirectory() as d:
            src, dst = os.path.join(d, "t.ply"), os.path.join(d, "t1.ply")
            with open(src, "w") as f:
                f.write("ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\n"
                        "element face 4\nproperty list uchar int vertex_indices\nend_header\n")
                f.writelines(f"{a} {b} {c}\n" for a, b, c in p)
                f.writelines(f"3 {a} {b} {c}\n" for a, b, c in faces)
            out = run("loop-subdivide", src, dst, "--levels", "1")
            self.assertEqual(out.returncode, 0, out.stderr)
            with open(dst) as f:
                lines = f.read().split("\n")
            body = lines[lines.index("end_header") + 1:]
            vertices = np.array([[float(x) for x in body[k].split()] for k in range(10)])
            self.assertEqual(len([l for l in body if l.startswith("3 ")]), 16)  # 4 x 4 triangles
            # Loop's vertex rule with valence 3: beta = (5/8 - (3/8 + cos(2 pi / 3) / 4)^2) / 3 = 3/16,
            # v' = (1 - 3 beta) v + beta (sum of neighbours) = 7/16 v + 3/16 (-v) = v / 4 here
            # (the neighbours of a vertex of this tetrahedron sum to -v).
            np.testing.assert_allclose(vertices[0], p[0] / 4.0, atol=1e-6)
            # edge rule: 3/8 (a + b) + 1/8 (c + d); for edge (0, 1) c, d = 2, 3: (3/8)(2, 0, 0) + (1/8)(-2, 0, 0)
            self.assertTrue(any(np.allclose(v, [0.5, 0.0, 0.0], atol=1e-6) for v in vertices[4:]))
        out = run("loop-subdivide", "/nonexistent.ply", os.path.join(tempfile.gettempdir(), "x.ply"))
        self.assertEqual(out.returncode, 2)
        self.assertIn("/nonexistent.ply", out.stderr)


if __name__ == "__main__":
    unittest.main()
