#!/usr/bin/env python3
"""People found and false users on synth datasets with and without --tall-clutter, with intervals.

usage: tall_clutter_report.py DATASET [DATASET ...]
       tall_clutter_report.py --sequences DATASET [DATASET ...]
       tall_clutter_report.py --paired SHORT TALL [SHORT TALL ...]
Each DATASET is a `depthpose synth` output directory next to DATASET.perframe.jsonl written by
`depthpose segeval --data DATASET --per-frame DATASET.perframe.jsonl` (docs/segmentation.md,
"Tall clutter"). Per dataset and pooled: people found over all people / >= 8 visible joints /
>= 0.05 m^2 in view with 95 % Wilson intervals (people treated as independent trials), false
users per frame with a 95 % bootstrap interval over frames (frames are independent scenes), and
each false user's cause: "body piece" (most of its pixels carry a body label: a person split in
two) or the clutter piece whose projected image box overlaps the user's box most (box IoU >= 0.1,
depth within 0.5 m + half the piece's footprint), else "other". Per clutter kind: pieces in view
(projected box meets the image, mean corner depth <= 8 m, the sensor range; approximate: a piece hidden behind
another counts) and the share of them that some false user matched, with Wilson intervals.
--sequences: the datasets are `synth --sequence` recordings (frames of one are not independent):
the pooled line then gives 95 % bootstrap intervals over the datasets, for every rate alike.
--paired takes pairs of datasets of the same seed without and with --tall-clutter (the same scenes
plus tall pieces) and sorts the people found without them but missed with them: "hidden" (fewer
than half of their pixels still in view) or "in view" (merged with a piece, or cut by one).
"""
import json
import math
import random
import sys

Z95 = 1.959963984540054
MAX_RANGE_M = 8.0  # a piece counts as in view when its projected box meets the image within the sensor range


def wilson(k, n):
    if n == 0:
        return (float("nan"), float("nan"))
    p = k / n
    d = 1 + Z95 * Z95 / n
    c = (p + Z95 * Z95 / (2 * n)) / d
    h = Z95 * math.sqrt(p * (1 - p) / n + Z95 * Z95 / (4 * n * n)) / d
    return (max(0.0, c - h), min(1.0, c + h))


def bootstrap_mean(values, rounds=2000, seed=1):
    rng = random.Random(seed)
    n = len(values)
    means = sorted(sum(values[rng.randrange(n)] for _ in range(n)) / n for _ in range(rounds))
    return (means[int(0.025 * rounds)], means[int(0.975 * rounds) - 1])


def camera_projector(meta, camera):
    """World (floor y = 0, x = camera's left, z forward) -> pixel (u, v) and depth, as synth.cc."""
    fx, fy, cx, cy = meta["fx"], meta["fy"], meta["cx"], meta["cy"]
    p, r = math.radians(-camera["pitch"]), math.radians(camera["roll"])
    rx = [[1, 0, 0], [0, math.cos(p), -math.sin(p)], [0, math.sin(p), math.cos(p)]]
    flip = [[-1, 0, 0], [0, 1, 0], [0, 0, 1]]
    rz = [[math.cos(r), -math.sin(r), 0], [math.sin(r), math.cos(r), 0], [0, 0, 1]]
    mul = lambda a, b: [[sum(a[i][k] * b[k][j] for k in range(3)) for j in range(3)] for i in range(3)]
    m = mul(mul(rz, flip), rx)
    h = camera["height"]

    def project(x, y, z):
        w = (x, y - h, z)
        q = [sum(m[i][j] * w[j] for j in range(3)) for i in range(3)]
        if q[2] <= 0.05:
            return None
        return (cx + fx * q[0] / q[2], cy - fy * q[1] / q[2], q[2])

    return project


def item_box(project, item, width, height):
    c, s = math.cos(math.radians(item["yaw"])), math.sin(math.radians(item["yaw"]))
    pts = []
    for lx in (-0.5 * item["width"], 0.5 * item["width"]):
        for lz in (-0.5 * item["depth"], 0.5 * item["depth"]):
            for y in (0.0, item["height"]):
                q = project(item["x"] + c * lx - s * lz, y, item["z"] + s * lx + c * lz)
                if q:
                    pts.append(q)
    if not pts:
        return None, None
    us, vs = [q[0] for q in pts], [q[1] for q in pts]
    box = [max(0, min(us)), max(0, min(vs)), min(width - 1, max(us)), min(height - 1, max(vs))]
    if box[0] > box[2] or box[1] > box[3]:
        return None, None
    return box, sum(q[2] for q in pts) / len(pts)


def box_iou(a, b):
    ix = max(0, min(a[2], b[2]) - max(a[0], b[0]) + 1)
    iy = max(0, min(a[3], b[3]) - max(a[1], b[1]) + 1)
    inter = ix * iy
    area = lambda r: (r[2] - r[0] + 1) * (r[3] - r[1] + 1)
    return inter / (area(a) + area(b) - inter)


def analyse(dataset):
    meta = json.load(open(dataset + "/meta.json"))
    truth = {}
    for line in open(dataset + "/frames.jsonl"):
        f = json.loads(line)
        truth[f["id"]] = f
    found = [0, 0, 0]
    people = [0, 0, 0]
    false_per_frame = []
    causes = {}
    in_view, became_user = {}, {}  # per clutter kind: pieces in view, pieces matched by a false user
    for line in open(dataset + ".perframe.jsonl"):
        r = json.loads(line)
        for p in r["people"]:
            sets = [p["pixels"] > 0, p["visible_joints"] >= 8, p["visible_area_m2"] >= 0.05]
            hit = p["user"] > 0  # 0 = no user matched
            for i, member in enumerate(sets):
                if member:
                    people[i] += 1
                    found[i] += hit
        false_users = [u for u in r["users"] if u["person"] is None or u["person"] < 0]
        false_per_frame.append(len(false_users))
        f = truth[r["id"]]
        project = camera_projector(meta, f["camera"])
        boxes = [item_box(project, item, meta["width"], meta["height"]) for item in f.get("clutter", [])]
        for item, (box, depth) in zip(f.get("clutter", []), boxes):
            if box is not None and depth <= MAX_RANGE_M:
                in_view[item["shape"]] = in_view.get(item["shape"], 0) + 1
        matched_items = set()
        for u in false_users:
            if u["body_pixels"] * 2 > u["pixels"]:
                cause = "body piece"
            else:
                cause, best, best_index = "other", 0.1, -1
                for index, (item, (box, depth)) in enumerate(zip(f.get("clutter", []), boxes)):
                    if box is None or abs(depth - u["z"]) > 0.5 + 0.5 * math.hypot(item["width"], item["depth"]):
                        continue
                    iou = box_iou(box, u["box"])
                    if iou >= best:
                        cause, best, best_index = item["shape"], iou, index
                if best_index >= 0 and best_index not in matched_items:
                    matched_items.add(best_index)
                    became_user[cause] = became_user.get(cause, 0) + 1
            causes[cause] = causes.get(cause, 0) + 1
    return found, people, false_per_frame, causes, in_view, became_user


def report(name, found, people, false_per_frame, causes, in_view, became_user):
    cells = []
    for k, n in zip(found, people):
        lo, hi = wilson(k, n)
        cells.append(f"{k}/{n} = {k / n:.4f} [{lo:.4f}, {hi:.4f}]")
    n = len(false_per_frame)
    lo, hi = bootstrap_mean(false_per_frame)
    total = sum(false_per_frame)
    frames_with = sum(1 for v in false_per_frame if v)
    cause_text = ", ".join(f"{k} {v}" for k, v in sorted(causes.items(), key=lambda kv: -kv[1]))
    kinds = []
    for kind, shown in sorted(in_view.items()):
        k = became_user.get(kind, 0)
        lo_k, hi_k = wilson(k, shown)
        kinds.append(f"{kind} {k}/{shown} = {k / shown:.3f} [{lo_k:.3f}, {hi_k:.3f}]")
    print(f"| {name} | {' / '.join(cells)} | {total} in {n} = {total / n:.4f} [{lo:.4f}, {hi:.4f}]; "
          f"{frames_with} frames with any | {cause_text or '-'} | {'; '.join(kinds)} |")


def people_by_frame(dataset):
    return {r["id"]: r["people"] for r in map(json.loads, open(dataset + ".perframe.jsonl"))}


def paired(pairs):
    found_short = lost = hidden = hidden_but_shown = 0
    for short, tall in pairs:
        tall_people = people_by_frame(tall)
        for frame, people in people_by_frame(short).items():
            for a, b in zip(people, tall_people[frame]):
                if a["user"] <= 0:
                    continue
                found_short += 1
                if b["user"] > 0:
                    continue
                lost += 1
                if b["pixels"] * 2 < a["pixels"]:
                    hidden += 1
                    hidden_but_shown += b["visible_area_m2"] >= 0.05
    print(f"found without tall pieces: {found_short}; missed with them: {lost} "
          f"(hidden: {hidden}, of them {hidden_but_shown} still with >= 0.05 m^2 in view; in view: {lost - hidden})")


def main():
    if len(sys.argv) < 2:
        sys.exit(__doc__)
    if sys.argv[1] == "--paired":
        rest = sys.argv[2:]
        if not rest or len(rest) % 2:
            sys.exit("--paired needs SHORT TALL dataset pairs")
        paired(list(zip(rest[0::2], rest[1::2])))
        return
    sequences = sys.argv[1] == "--sequences"
    datasets = sys.argv[2:] if sequences else sys.argv[1:]
    pooled = ([0, 0, 0], [0, 0, 0], [], {}, {}, {})
    per_dataset = []
    for dataset in datasets:
        found, people, fpf, causes, in_view, became_user = analyse(dataset)
        per_dataset.append((found, people, fpf))
        report(dataset, found, people, fpf, causes, in_view, became_user)
        for i in range(3):
            pooled[0][i] += found[i]
            pooled[1][i] += people[i]
        pooled[2].extend(fpf)
        for into, counts in ((pooled[3], causes), (pooled[4], in_view), (pooled[5], became_user)):
            for k, v in counts.items():
                into[k] = into.get(k, 0) + v
    if len(datasets) > 1:
        report("pooled", *pooled)
    if sequences:
        sequence_bootstrap(per_dataset)


def sequence_bootstrap(per_dataset, rounds=2000, seed=1):
    """95 % bootstrap intervals over whole datasets: people found (3 sets) and false users per frame."""
    rng = random.Random(seed)
    n = len(per_dataset)
    samples = [[] for _ in range(4)]
    for _ in range(rounds):
        pick = [per_dataset[rng.randrange(n)] for _ in range(n)]
        for i in range(3):
            people = sum(d[1][i] for d in pick)
            samples[i].append(sum(d[0][i] for d in pick) / people if people else float("nan"))
        samples[3].append(sum(sum(d[2]) for d in pick) / sum(len(d[2]) for d in pick))
    names = ["people found (all)", "people found (>= 8 joints)", "people found (>= 0.05 m^2)", "false users per frame"]
    for name, values in zip(names, samples):
        values.sort()
        print(f"  bootstrap over {n} sequences, {name}: [{values[int(0.025 * rounds)]:.4f}, "
              f"{values[int(0.975 * rounds) - 1]:.4f}]")


if __name__ == "__main__":
    main()
