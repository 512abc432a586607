#!/usr/bin/env python3
"""The accuracy tables of docs/results.md, from what `make model` left in MODEL_DIR.

usage: model_report.py MODEL_DIR

Reads MODEL_DIR/eval_{bpc,ojr}.json (the new blobs on the held-out test split), the
eval_old_{bpc,ojr}.json beside them when the replaced blobs were scored too, and tune_{bpc,ojr}.json
(validation mAP before and after tuning), and prints Markdown: overall mAP new beside old, mAP per
held-out motion category, AP per joint (joints below 0.5 marked), mAP against D_tp. A missing new
eval is an error naming the file; a missing old one leaves its columns out.
"""
import json
import os
import sys

METHODS = ("bpc", "ojr")
FLOOR = 0.5  # a joint AP below this is marked: the floor for every joint


def load(path, required):
    if not os.path.exists(path):
        if required:
            sys.exit(f"model_report: {path} is missing (run make model to the eval step first)")
        return None
    with open(path) as f:
        try:
            return json.load(f)
        except json.JSONDecodeError as e:
            sys.exit(f"model_report: {path} is not JSON: {e}")


def columns(model_dir):
    """(label, eval JSON) per column: new BPC, old BPC, new OJR, old OJR (old ones when present)."""
    cols = []
    for m in METHODS:
        cols.append((f"{m.upper()} new", load(os.path.join(model_dir, f"eval_{m}.json"), True)))
        old = load(os.path.join(model_dir, f"eval_old_{m}.json"), False)
        if old is not None:
            cols.append((f"{m.upper()} old", old))
    return cols


def fmt(x, mark_low=False):
    if x is None:
        return "–"
    s = f"{x:.3f}"
    return f"**{s}**" if mark_low and x < FLOOR else s


def row(cells):
    return "| " + " | ".join(cells) + " |"


def table(header, rows):
    out = [row(header), row(["---"] * len(header))]
    out += [row(r) for r in rows]
    return "\n".join(out)


def section(out, caption, header, rows):
    """Appends a caption line and its table, each followed by a blank line."""
    out += [caption, "", table(header, rows), ""]


def main():
    if len(sys.argv) != 2:
        sys.exit(__doc__.strip())
    model_dir = sys.argv[1]
    cols = columns(model_dir)
    labels = [c[0] for c in cols]
    evals = [c[1] for c in cols]
    first = evals[0]
    out = []

    out.append(f"Held-out test split: {first['frames']} frames, D_tp = {first['d_tp']} m, "
               f"invisible joints {'penalized' if first['penalize_occluded'] else 'not penalized'}.")
    out.append("")
    overall = [["**mAP**"] + [f"**{e['mAP']:.3f}**" for e in evals],
               ["per-class segmentation accuracy"] +
               [fmt(e["class_accuracy"]) if e["method"] == "BPC" else "–" for e in evals],
               ["joints below 0.5"] +
               [str(sum(1 for v in e["per_joint_ap"].values() if v < FLOOR)) for e in evals]]
    out.append(table([""] + labels, overall))
    out.append("")

    tunes = [(m, load(os.path.join(model_dir, f"tune_{m}.json"), False)) for m in METHODS]
    tune_rows = [[m.upper(), str(t["frames"]), f"{t['mAP_before']:.3f} → {t['mAP_after']:.3f}", str(t["nsub"])]
                 for m, t in tunes if t is not None]
    if tune_rows:
        section(out, "Tuning on the validation split (`depthpose tune`; per-joint bandwidth, vote length, "
                "push-back and probability threshold, then Nsub):",
                ["", "validation frames", "validation mAP before → after", "Nsub"], tune_rows)

    categories = sorted({c for e in evals for c in e.get("by_category", {})})
    if categories:
        rows = []
        for c in categories:
            frames = next(e["by_category"][c]["frames"] for e in evals if c in e.get("by_category", {}))
            rows.append([c, str(frames)] +
                        [fmt(e.get("by_category", {}).get(c, {}).get("mAP")) for e in evals])
        section(out, "mAP per held-out motion category (frames of the test split in each):",
                ["category", "frames"] + labels, rows)

    # The blob's joint order, as `eval --json` lists it (its per-joint objects are keyed by name);
    # an evaluation written before that field existed gives its keys' order.
    joints = first.get("joints") or list(first["per_joint_ap"].keys())
    section(out, f"AP per joint (below {FLOOR} in bold):", ["joint"] + labels,
            [[j] + [fmt(e["per_joint_ap"].get(j), True) for e in evals] for j in joints])

    radii = [p["d_tp"] for p in first["ap_vs_dtp"]]
    rows = []
    for r in radii:
        cells = []
        for e in evals:
            hit = [p["mAP"] for p in e["ap_vs_dtp"] if abs(p["d_tp"] - r) < 1e-9]
            cells.append(fmt(hit[0] if hit else None))
        rows.append([f"{r:.2f}"] + cells)
    section(out, "mAP against the true-positive radius:", ["D_tp (m)"] + labels, rows)

    speed_rows = []
    for label, e in cols:
        s = e.get("speed")
        if s:
            stages = " + ".join(f"{k} {v:.3f}" for k, v in s["stage_ms"].items() if v > 0)
            speed_rows.append([label, f"{s['fps']:.0f}", f"{s['mean_evaluated_pixels']:.0f}", stages])
    if speed_rows:
        section(out, "Speed inside `depthpose eval` (one core, the test split's frames, not a benchmark: "
                "`make bench` measures speed):", ["blob", "frames/s", "evaluated pixels/frame", "ms per stage"],
                speed_rows)
    print("\n".join(out).rstrip())


if __name__ == "__main__":
    main()
