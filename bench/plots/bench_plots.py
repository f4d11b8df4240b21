#!/usr/bin/env python3
"""Plots of `lightskin bench` drawn from its bench.json (docs/BENCHMARKS.md, "Plots").

    python3 bench/plots/bench_plots.py bench-out/bench.json bench-out

writes into the output folder:
  bench.png            error against the ray-traced truth vs time per frame (Pareto plot, log-log)
  bench-vs-brute.png   the same against the brute force on the same VALs
  bench-scaling.png    time per frame vs VAL count, per technique and backend
  bench-flicker.png    temporal stability: flicker and excess flicker per sequence and technique
  bench-plots.json     what was drawn (series, colours, markers, labels and their overlaps), for tests

Series are the (method, backend) pairs found in the JSON (runs[].method / runs[].backend; older files
without them: "LightSkin"/"brute force" on "GL"), so a new technique or backend needs no change here.
Exit status: 0 plotted, 2 bad input (message names the file and key), 3 matplotlib missing.
"""
import json
import math
import os
import sys

EXIT_BAD_INPUT = 2
EXIT_NO_MATPLOTLIB = 3

try:
    import matplotlib

    matplotlib.use("Agg")  # headless: no display on CI or the bench machine
    import matplotlib.pyplot as plt
    from matplotlib.lines import Line2D
    from matplotlib.ticker import LogFormatterSciNotation
except ImportError as error:
    print(f"bench_plots.py: matplotlib is not available ({error}); install python3-matplotlib", file=sys.stderr)
    sys.exit(EXIT_NO_MATPLOTLIB)

# One colour per series in order of appearance (colour-blind safe Okabe-Ito palette), one marker per
# method: the brute force always black squares, the reference every other series is judged against.
PALETTE = ["#0072B2", "#D55E00", "#009E73", "#CC79A7", "#E69F00", "#56B4E9", "#F0E442", "#882255"]
MARKERS = ["o", "^", "D", "v", "P", "X", "<", ">"]
BRUTE = "brute force"


class BadInput(Exception):
    pass


def field(obj, key, where):
    if key not in obj:
        raise BadInput(f"{where}: missing key '{key}'")
    return obj[key]


def method_of(run):
    return run.get("method") or (BRUTE if run.get("is_brute") else "LightSkin")


def backend_of(run):
    return run.get("backend") or "GL"


def time_of(run, where):
    """Time per frame of the run's own technique (ms): GPU timer sum, or the brute force's time on its row."""
    if "time_ms" in run and run["time_ms"] is not None:
        return float(run["time_ms"])
    key = "brute_ms" if run.get("is_brute") else "gpu_ms"
    value = field(run, key, where)
    return None if value is None else float(value)


class Styles:
    """Colour and marker per (method, backend), fixed for all plots of one JSON."""

    def __init__(self, keys):
        self.style = {}
        methods = []
        for key in keys:
            if key[0] not in methods and key[0] != BRUTE:
                methods.append(key[0])
        colour, brutes = 0, 0
        for key in keys:
            if key in self.style:
                continue
            if key[0] == BRUTE:
                self.style[key] = (["#000000", "#777777", "#BBBBBB"][min(brutes, 2)], "s")
                brutes += 1
            else:
                self.style[key] = (PALETTE[colour % len(PALETTE)], MARKERS[methods.index(key[0]) % len(MARKERS)])
                colour += 1

    def __call__(self, key):
        return self.style[key]


def series_name(key):
    return f"{key[0]} ({key[1]})"


def place_labels(ax, fig, items, avoid_points):
    """Labels beside their points without overlaps: each label takes the first of a ring of candidate
    offsets (growing radii) whose box hits no placed label, no other data point and stays inside the axes.
    Returns the label boxes (display coordinates) and how many still overlap (0 unless the plot is too full)."""
    renderer = fig.canvas.get_renderer()
    axes_box = ax.get_window_extent(renderer)
    placed, texts = [], []
    point_boxes = []
    for x, y in avoid_points:
        px, py = ax.transData.transform((x, y))
        point_boxes.append((px - 5, py - 5, px + 5, py + 5))

    def overlaps(a, b):
        return a[0] < b[2] and b[0] < a[2] and a[1] < b[3] and b[1] < a[3]

    offsets = []
    for radius in (8, 16, 26, 40, 58, 80):
        for dx, dy in ((1, 1), (1, -1), (-1, 1), (-1, -1), (1, 0), (-1, 0), (0, 1), (0, -1)):
            offsets.append((dx * radius, dy * radius))
    for (x, y, text, weight) in items:
        own = ax.transData.transform((x, y))
        chosen, first = None, None
        for dx, dy in offsets:
            t = ax.annotate(text, (x, y), xytext=(dx, dy), textcoords="offset points", fontsize=8, fontweight=weight,
                            ha="left" if dx >= 0 else "right", va="bottom" if dy >= 0 else "top",
                            arrowprops=dict(arrowstyle="-", color="0.5", lw=0.6) if abs(dx) > 10 else None)
            b = t.get_window_extent(renderer)
            box = (b.x0, b.y0, b.x1, b.y1)
            inside = (box[0] >= axes_box.x0 and box[2] <= axes_box.x1 and box[1] >= axes_box.y0 and
                      box[3] <= axes_box.y1)
            hits = any(overlaps(box, p) for p in placed) or any(
                overlaps(box, pb) for pb in point_boxes
                if abs(pb[0] + 5 - own[0]) > 1e-6 or abs(pb[1] + 5 - own[1]) > 1e-6)
            if inside and not hits:
                chosen = (t, box)
                break
            if first is None:
                first = (t, box)  # kept if no candidate fits (then counted as an overlap below)
            else:
                t.remove()
        if chosen is None:
            chosen = first
        elif first is not None:
            first[0].remove()
        t, box = chosen
        placed.append(box)
        texts.append({"text": text, "box": [float(v) for v in box]})
    overlap_count = sum(1 for i in range(len(placed)) for j in range(i) if overlaps(placed[i], placed[j]))
    return texts, overlap_count


def pareto_plot(report, truth, path, manifest, styles):
    key_err = "vs_truth" if truth else "vs_brute"
    runs = field(report, "runs", "bench.json")
    default_channels = next((r.get("channels") for r in runs if r.get("is_default") and not r.get("is_brute")), None)
    points = []
    for i, r in enumerate(runs):
        where = f"bench.json runs[{i}]"
        err = r.get(key_err)
        t = time_of(r, where)
        if not err or t is None or t <= 0:
            continue
        e = float(field(err, "relative_mse", f"{where}.{key_err}"))
        if e <= 0:
            continue
        points.append({"t": t, "e": e, "run": r, "key": (method_of(r), backend_of(r)),
                       "own_reference": r.get("channels") == default_channels or r.get("is_brute")})
    fig, ax = plt.subplots(figsize=(10, 6.2), dpi=110)
    ax.set_xscale("log")
    ax.set_yscale("log")
    # Errors often span less than two decades: label the minor ticks too, or the axis has one number.
    ax.yaxis.set_minor_formatter(LogFormatterSciNotation(labelOnlyBase=False, minor_thresholds=(2, 0.5)))
    ax.grid(True, which="major", color="0.8")
    ax.grid(True, which="minor", color="0.93")
    ax.set_xlabel("time per frame (ms, log): GPU timer sum (GL), wall time (CPU backend)")
    ax.set_ylabel("relative MSE of the indirect light (log)")
    reference = "the ray-traced ground truth (Embree)" if truth else "the brute force on the same VALs"
    ax.set_title(f"lightskin bench: error against {reference} vs time\n{report.get('renderer', '')}", fontsize=10)
    drawn = {}
    for p in points:
        colour, marker = styles(p["key"])
        face = colour if p["own_reference"] else "none"
        ax.scatter([p["t"]], [p["e"]], s=46, marker=marker, facecolors=face, edgecolors=colour, linewidths=1.2,
                   zorder=3)
        drawn.setdefault(p["key"], 0)
        drawn[p["key"]] += 1
    # Pareto front over the points judged against the same reference as the default (other channel sets
    # have their own reference images): none of them is both faster and more accurate.
    front = []
    best = math.inf
    for p in sorted((p for p in points if p["own_reference"]), key=lambda p: (p["t"], p["e"])):
        if p["e"] < best:
            best = p["e"]
            front.append(p)
    if len(front) > 1:
        ax.plot([p["t"] for p in front], [p["e"] for p in front], color="0.35", lw=1.2, ls="--", zorder=2)
    defaults = [p for p in points if p["run"].get("is_default") and not p["run"].get("is_brute")]
    for p in defaults:
        ax.scatter([p["t"]], [p["e"]], s=230, marker="o", facecolors="none", edgecolors="#C00000", linewidths=2,
                   zorder=4)
    if points:  # margins so that labels fit inside the axes on log scales
        ts = [p["t"] for p in points]
        es = [p["e"] for p in points]
        ax.set_xlim(min(ts) / 2.5, max(ts) * 2.5)
        ax.set_ylim(min(es) / 2.5, max(es) * 2.5)
    # Labels only where they carry information: the default (on each backend), the brute force, the Pareto front
    # and the first row of every other technique (its paper's setting, e.g. imperfect volumes' 64^3/12/100); the
    # other points are identified by colour and the table in bench.md.
    labelled = []
    first_of_technique = {}
    for p in points:
        if p["key"][0] not in ("LightSkin", BRUTE):
            first_of_technique.setdefault(p["key"][0], p)
    for p in points:
        r = p["run"]
        is_default = r.get("is_default") and not r.get("is_brute")
        # A row of the "backend" axis is the default configuration on another backend.
        other_backend_default = r.get("axis") == "backend"
        technique_first = any(p is q for q in first_of_technique.values())
        if is_default or other_backend_default or r.get("is_brute") or technique_first or any(p is q for q in front):
            text = "default" if other_backend_default else r.get("label", "?")
            if p["key"] != ("LightSkin", "GL") and p["key"][0] != BRUTE:
                text = f"{series_name(p['key'])}: {text}"  # the same knob label on several series
            labelled.append((p["t"], p["e"], text, "bold" if is_default or r.get("is_brute") else "normal"))
    handles = [Line2D([], [], ls="none", marker=styles(k)[1], color=styles(k)[0], markersize=7, label=series_name(k))
               for k in drawn]
    handles += [Line2D([], [], ls="--", color="0.35", label="Pareto front"),
                Line2D([], [], ls="none", marker="o", markersize=13, markerfacecolor="none", markeredgecolor="#C00000",
                       markeredgewidth=2, label="default configuration"),
                Line2D([], [], ls="none", marker="o", markerfacecolor="none", markeredgecolor="0.3", markersize=7,
                       label="other channels (own reference)")]
    ax.legend(handles=handles, loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8, frameon=False)
    fig.tight_layout()
    fig.canvas.draw()
    texts, overlap_count = place_labels(ax, fig, labelled, [(p["t"], p["e"]) for p in points])
    fig.savefig(path)
    plt.close(fig)
    manifest[os.path.basename(path)] = {
        "series": [{"method": k[0], "backend": k[1], "colour": styles(k)[0], "marker": styles(k)[1], "points": n}
                   for k, n in drawn.items()],
        "pareto_front": [p["run"].get("label") for p in front],
        "labels": texts, "label_overlaps": overlap_count}


def scaling_plot(report, path, manifest, styles):
    """Time per frame against VAL count: the runs that vary only the VAL map (axis stride, and the default),
    per (method, backend); a LightSkin row's brute_ms (the brute force on its inputs) joins the brute force."""
    series = {}
    for i, r in enumerate(field(report, "runs", "bench.json")):
        if r.get("axis") not in ("stride", "default"):
            continue
        vals = field(r, "vals", f"bench.json runs[{i}]")
        t = time_of(r, f"bench.json runs[{i}]")
        if t and vals:
            series.setdefault((method_of(r), backend_of(r)), {})[vals] = t
        if not r.get("is_brute") and r.get("brute_ms") and vals:
            series.setdefault((BRUTE, backend_of(r)), {})[vals] = float(r["brute_ms"])
    fig, ax = plt.subplots(figsize=(8, 5.5), dpi=110)
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.grid(True, which="both", color="0.88")
    for key, points in series.items():
        xs = sorted(points)
        colour, marker = styles(key)
        ax.plot(xs, [points[x] for x in xs], marker=marker, color=colour, label=series_name(key))
    ax.set_xlabel("VALs (log)")
    ax.set_ylabel("time per frame (ms, log)")
    ax.set_title("lightskin bench: time against VAL count (the VAL-stride runs)", fontsize=10)
    if series:
        ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)
    manifest[os.path.basename(path)] = {
        "series": [{"method": k[0], "backend": k[1], "colour": styles(k)[0], "marker": styles(k)[1],
                    "points": len(v)} for k, v in series.items()]}


def flicker_plot(report, path, manifest):
    """Grouped bars per sequence: flicker of each technique (the brute force's is the reference floor) and,
    below, the excess flicker the approximation adds."""
    temporal = report.get("temporal") or []
    sequences, techniques = [], []
    for t in temporal:
        if t["sequence"] not in sequences:
            sequences.append(t["sequence"])
        if t["technique"] not in techniques:
            techniques.append(t["technique"])
    fig, (top, bottom) = plt.subplots(2, 1, figsize=(9, 6.5), dpi=110, sharex=True)
    width = 0.8 / max(1, len(techniques))
    colours = {}
    c = 0
    for name in techniques:
        if name.startswith(BRUTE):
            colours[name] = "#000000"
        else:
            colours[name] = PALETTE[c % len(PALETTE)]
            c += 1
    for j, name in enumerate(techniques):
        xs, flicker, excess = [], [], []
        for i, s in enumerate(sequences):
            row = next((t for t in temporal if t["sequence"] == s and t["technique"] == name), None)
            if row:
                xs.append(i + (j - (len(techniques) - 1) / 2) * width)
                flicker.append(row["flicker"])
                excess.append(row["excess_flicker"])
        top.bar(xs, flicker, width * 0.95, color=colours[name], label=name)
        bottom.bar(xs, excess, width * 0.95, color=colours[name])
    top.set_ylabel("flicker\n(RMS change / mean)")
    bottom.set_ylabel("excess flicker\n(over the reference)")
    bottom.set_xticks(range(len(sequences)))
    bottom.set_xticklabels(sequences)
    bottom.set_xlabel("sequence: camera = moving view, light = moving light, edges = moving depth camera")
    top.set_title("lightskin bench: temporal stability", fontsize=10)
    if techniques:
        top.legend(fontsize=8)
    for ax in (top, bottom):
        ax.grid(True, axis="y", color="0.88")
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)
    manifest[os.path.basename(path)] = {"sequences": sequences, "techniques": techniques}


def main(argv):
    if len(argv) != 3:
        print("usage: bench_plots.py BENCH_JSON OUT_DIR", file=sys.stderr)
        return EXIT_BAD_INPUT
    json_path, out = argv[1], argv[2]
    try:
        with open(json_path, encoding="utf-8") as f:
            report = json.load(f)
    except (OSError, ValueError) as error:
        print(f"bench_plots.py: {json_path}: cannot read the bench JSON: {error}", file=sys.stderr)
        return EXIT_BAD_INPUT
    try:
        runs = field(report, "runs", json_path)
        keys = [(method_of(r), backend_of(r)) for r in runs]
        keys += [(BRUTE, backend_of(r)) for r in runs if r.get("brute_ms")]
        styles = Styles(keys)
        os.makedirs(out, exist_ok=True)
        manifest = {"source": json_path}
        pareto_plot(report, True, os.path.join(out, "bench.png"), manifest, styles)
        pareto_plot(report, False, os.path.join(out, "bench-vs-brute.png"), manifest, styles)
        scaling_plot(report, os.path.join(out, "bench-scaling.png"), manifest, styles)
        flicker_plot(report, os.path.join(out, "bench-flicker.png"), manifest)
    except (BadInput, KeyError, TypeError, ValueError) as error:
        print(f"bench_plots.py: {json_path}: {error}", file=sys.stderr)
        return EXIT_BAD_INPUT
    with open(os.path.join(out, "bench-plots.json"), "w", encoding="utf-8") as f:
        json.dump(manifest, f, indent=2)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
