#!/usr/bin/env python3
"""Derive a rig file with partial views from a full one.

    make_partial.py IN.json OUT.json [--fraction 0.3] [--seed 1]

In a --fraction of the observations (chosen with --seed) the camera misses the board's first
row of corners, as when the board's edge leaves the image: the observation gets its own
object_points (the rest of the board) and the matching image_points, as docs/formats.md allows.
The truth key is kept. Used by run.sh for the partial-view data set.
"""

import argparse
import json
import random


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("inp")
    ap.add_argument("out")
    ap.add_argument("--fraction", type=float, default=0.3)
    ap.add_argument("--seed", type=int, default=1)
    a = ap.parse_args()
    with open(a.inp) as f:
        d = json.load(f)
    cols = int(d["board"]["cols"])
    rng = random.Random(a.seed)
    partial = 0
    for fr in d["frames"]:
        for o in fr["observations"]:
            if "object_points" in o or rng.random() >= a.fraction:
                continue
            o["object_points"] = fr["object_points"][cols:]
            o["image_points"] = o["image_points"][cols:]
            partial += 1
    d["name"] = d.get("name", "") + f", first row missing in {partial} views"
    with open(a.out, "w") as f:
        json.dump(d, f)
    print(f"{partial} partial views")


if __name__ == "__main__":
    main()
