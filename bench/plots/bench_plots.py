#!/usr/bin/env python3
"""Plots of the bench JSON (`lightskin bench`, bench-gather, bench-cpu, bench-realdepth; keys in
docs/bench/SCHEMA.md; how to read the plots: docs/BENCHMARKS.md, "Plots").

    python3 bench/plots/bench_plots.py bench-out/bench.json bench-out

writes into the output folder, named by the JSON's "bench" key (B; "bench" for files without it):
  B.png            error against the ray-traced truth vs time per frame (Pareto plot, log-log)
  B-vs-brute.png   the same against the brute force on the same VALs
  B-scaling.png    time per frame vs VAL count, per technique and backend (and series)
  B-flicker.png    temporal stability: flicker and excess flicker per sequence and technique
  B-plots.json     what was drawn (series, colours, markers, labels and their overlaps), for tests
A plot whose rows the JSON lacks (no errors, no VAL counts, no temporal rows) is not written.

Series are the (method, backend) pairs found in the JSON (runs[].method / runs[].backend; older files
without them: "LightSkin"/"brute force" on "GL"). The known techniques (TECHNIQUES) keep one colour and
marker in every plot and file, whichever spelling of their method key a file uses; any other method
gets the next free colour, so a new technique needs no change here to be drawn.
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

# Colour-blind safe (Okabe-Ito). The known techniques own a hue each (GL backend) and a lighter one (CPU
# backend), and a marker; the brute force is black squares, the reference the others are judged against.
# Keys are compared without case, spaces, '-' and '_': "multiscale-prt" = "multi-scale PRT".
TECHNIQUES = [
    # (key, display name, marker, {backend: colour})
    ("lightskin", "LightSkin", "o", {"gl": "#0072B2", "cpu": "#56B4E9"}),
    ("imperfectvolumes", "imperfect volumes", "^", {"gl": "#D55E00", "cpu": "#E69F00"}),
    ("multiscaleprt", "multi-scale PRT", "D", {"gl": "#009E73", "cpu": "#66C2A5"}),
]
# For any other (method, backend): colours and markers no known technique uses.
SPARE_COLOURS = ["#CC79A7", "#882255", "#F0E442", "#44AA99", "#999933", "#AA4499"]
SPARE_MARKERS = ["v", "P", "X", "<", ">", "h"]
BRUTE = "brute force"
BRUTE_COLOURS = ["#000000", "#777777", "#BBBBBB"]
LINE_STYLES = ["-", "--", ":", "-."]
HATCHES = ["", "//", "..", "xx", "\\\\", "++"]


def technique_key(method):
    return "".join(c for c in str(method).lower() if c not in " -_")


def known_technique(method):
    key = technique_key(method)
    return next((t for t in TECHNIQUES if t[0] == key), None)


def display_name(method):
    known = known_technique(method)
    if known:
        return known[1]
    return BRUTE if technique_key(method) == technique_key(BRUTE) else str(method)


class BadInput(Exception):
    pass


def field(obj, key, where):
    if key not in obj:
        raise BadInput(f"{where}: missing key '{key}'")
    return obj[key]


def method_of(run):
    """The run's technique by its display name (one series whichever spelling of a known key it uses)."""
    return display_name(run.get("method") or (BRUTE if run.get("is_brute") else "LightSkin"))


def backend_of(run):
    # Backends are spelled "gl"/"cpu" (gi::toString(Backend)); files before that said "GL"/"CPU".
    return (run.get("backend") or "gl").lower()


def time_of(run, where):
    """Time per frame of the run's own technique (ms): GPU timer sum, or the brute force's time on its row."""
    if "time_ms" in run and run["time_ms"] is not None:
        return float(run["time_ms"])
    key = "brute_ms" if run.get("is_brute") else "gpu_ms"
    value = field(run, key, where)
    return None if value is None else float(value)


class Styles:
    """Colour and marker per (method, backend), fixed for all plots of one JSON: the known techniques'
    own (TECHNIQUES), the brute force black, others the spare colours in order of appearance."""

    def __init__(self, keys):
        self.style = {}
        spare_methods, spare, brutes = [], 0, 0
        for key in keys:
            if key in self.style:
                continue
            known = known_technique(key[0])
            if technique_key(key[0]) == technique_key(BRUTE):
                self.style[key] = (BRUTE_COLOURS[min(brutes, len(BRUTE_COLOURS) - 1)], "s")
                brutes += 1
            elif known and key[1] in known[3]:
                self.style[key] = (known[3][key[1]], known[2])
            else:
                if technique_key(key[0]) not in spare_methods:
                    spare_methods.append(technique_key(key[0]))
                marker = known[2] if known else SPARE_MARKERS[
                    spare_methods.index(technique_key(key[0])) % len(SPARE_MARKERS)]
                self.style[key] = (SPARE_COLOURS[spare % len(SPARE_COLOURS)], marker)
                spare += 1

    def __call__(self, key):
        return self.style[key]


def series_name(key):
    return f"{display_name(key[0])} ({key[1]})"


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
    if not points:
        return False
    fig, ax = plt.subplots(figsize=(10, 6.2), dpi=110)
    ax.set_xscale("log")
    ax.set_yscale("log")
    # Errors often span less than two decades: label the minor ticks too, or the axis has one number.
    ax.yaxis.set_minor_formatter(LogFormatterSciNotation(labelOnlyBase=False, minor_thresholds=(2, 0.5)))
    ax.grid(True, which="major", color="0.8")
    ax.grid(True, which="minor", color="0.93")
    ax.set_xlabel("time per frame (ms, log): stage-time sum; GL by timer queries, CPU stages by wall clock")
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
            if p["key"] != ("LightSkin", "gl") and p["key"][0] != BRUTE:
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
    return True


def scaling_plot(report, path, manifest, styles):
    """Time per frame against VAL count, one line per (method, backend, series). The sweep (bench.json):
    the runs that vary only the VAL map (axis stride, and the default), and a LightSkin row's brute_ms (the
    brute force on its inputs) joins the brute force; the table benches: every row with a VAL count."""
    sweep = report.get("bench", "bench") == "bench"
    series = {}
    for i, r in enumerate(field(report, "runs", "bench.json")):
        if sweep and r.get("axis") not in ("stride", "default"):
            continue
        vals = field(r, "vals", f"bench.json runs[{i}]")
        t = time_of(r, f"bench.json runs[{i}]")
        variant = "" if r.get("is_brute") and sweep else (r.get("series") or "")
        if t and vals:
            series.setdefault((method_of(r), backend_of(r), variant), {})[vals] = t
        if sweep and not r.get("is_brute") and r.get("brute_ms") and vals:
            series.setdefault((BRUTE, backend_of(r), ""), {})[vals] = float(r["brute_ms"])
    if not series:
        return False
    fig, ax = plt.subplots(figsize=(10, 5.8), dpi=110)
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.grid(True, which="both", color="0.88")
    variants = {}  # line style per series within one (method, backend): colour says technique and backend
    drawn = []
    for key, points in series.items():
        xs = sorted(points)
        colour, marker = styles(key[:2])
        same = variants.setdefault(key[:2], [])
        same.append(key[2])
        style = LINE_STYLES[(len(same) - 1) % len(LINE_STYLES)]
        label = series_name(key[:2]) + (f": {key[2]}" if key[2] else "")
        ax.plot(xs, [points[x] for x in xs], marker=marker, color=colour, ls=style, label=label)
        drawn.append({"method": key[0], "backend": key[1], "series": key[2], "colour": colour, "marker": marker,
                      "linestyle": style, "points": len(xs), "label": label})
    ax.set_xlabel("VALs (log)")
    ax.set_ylabel("time per frame (ms, log)")
    what = " (the VAL-stride runs)" if sweep else ""  # the table benches' command is in their JSON
    ax.set_title(f"lightskin {report.get('bench', 'bench')}: time against VAL count{what}\n"
                 f"{report.get('renderer', '')}", fontsize=9)
    ax.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.01, 1.0), frameon=False)
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)
    manifest[os.path.basename(path)] = {"series": drawn}
    return True


def temporal_method(row):
    return display_name(row.get("method") or (BRUTE if str(row.get("technique", "")).startswith(BRUTE)
                                              else "LightSkin"))


def flicker_plot(report, path, manifest, styles):
    """Grouped bars per sequence: flicker of each technique (the brute force's is the reference floor) and,
    below, the excess flicker the approximation adds. A bar's colour is its technique's (as in the other
    plots); variants of one technique (sparse counts, light models) differ by hatching."""
    temporal = report.get("temporal") or []
    if not temporal:
        return False
    sequences, techniques = [], []
    for t in temporal:
        if t["sequence"] not in sequences:
            sequences.append(t["sequence"])
        if t["technique"] not in techniques:
            techniques.append(t["technique"])
    fig, (top, bottom) = plt.subplots(2, 1, figsize=(10, 6.5), dpi=110, sharex=True)
    width = 0.8 / max(1, len(techniques))
    colours, hatches, variants = {}, {}, {}
    for name in techniques:
        row = next(t for t in temporal if t["technique"] == name)
        key = (temporal_method(row), backend_of(row))
        colours[name] = styles(key)[0]
        same = variants.setdefault(key, [])
        same.append(name)
        hatches[name] = HATCHES[(len(same) - 1) % len(HATCHES)]
    for j, name in enumerate(techniques):
        xs, flicker, excess = [], [], []
        for i, s in enumerate(sequences):
            row = next((t for t in temporal if t["sequence"] == s and t["technique"] == name), None)
            if row:
                xs.append(i + (j - (len(techniques) - 1) / 2) * width)
                flicker.append(row["flicker"])
                excess.append(row["excess_flicker"])
        top.bar(xs, flicker, width * 0.95, color=colours[name], hatch=hatches[name], edgecolor="white", label=name)
        bottom.bar(xs, excess, width * 0.95, color=colours[name], hatch=hatches[name], edgecolor="white")
    top.set_ylabel("flicker\n(RMS change / mean)")
    bottom.set_ylabel("excess flicker\n(over the reference)")
    bottom.set_xticks(range(len(sequences)))
    bottom.set_xticklabels(sequences, fontsize=8, rotation=20 if len(sequences) > 4 else 0)
    if report.get("bench", "bench") == "bench":
        bottom.set_xlabel("sequence: camera = moving view, light = moving light, edges = moving depth camera")
    top.set_title(f"lightskin {report.get('bench', 'bench')}: temporal stability", fontsize=10)
    top.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.01, 1.0), frameon=False)
    for ax in (top, bottom):
        ax.grid(True, axis="y", color="0.88")
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)
    manifest[os.path.basename(path)] = {"sequences": sequences, "techniques": techniques,
                                        "colours": [colours[n] for n in techniques],
                                        "hatches": [hatches[n] for n in techniques]}
    return True


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
    # Outputs are named after the bench that wrote the file (bench.png, ...; bench-gather-scaling.png, ...).
    stem = report.get("bench", "bench") if isinstance(report, dict) else "bench"
    try:
        runs = field(report, "runs", json_path)
        keys = [(method_of(r), backend_of(r)) for r in runs]
        keys += [(BRUTE, backend_of(r)) for r in runs if r.get("brute_ms")]
        keys += [(temporal_method(t), backend_of(t)) for t in report.get("temporal") or []]
        styles = Styles(keys)
        os.makedirs(out, exist_ok=True)
        manifest = {"source": json_path, "drawn": []}
        plots = [(f"{stem}.png", lambda p: pareto_plot(report, True, p, manifest, styles)),
                 (f"{stem}-vs-brute.png", lambda p: pareto_plot(report, False, p, manifest, styles)),
                 (f"{stem}-scaling.png", lambda p: scaling_plot(report, p, manifest, styles)),
                 (f"{stem}-flicker.png", lambda p: flicker_plot(report, p, manifest, styles))]
        for name, draw in plots:
            if draw(os.path.join(out, name)):
                manifest["drawn"].append(name)
    except (BadInput, KeyError, TypeError, ValueError) as error:
        print(f"bench_plots.py: {json_path}: {error}", file=sys.stderr)
        return EXIT_BAD_INPUT
    with open(os.path.join(out, f"{stem}-plots.json"), "w", encoding="utf-8") as f:
        json.dump(manifest, f, indent=2)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
