#!/usr/bin/env python3
"""Checks a demo run's outputs (scripts/demo.sh OUT_DIR ...) against floors:
summary.json numbers, one colour-mapped depth image per keyframe, a PLY with
the reported point count and, with --picture, a non-blank rviz PNG (and with
--follow_picture the same of map_follow_rviz.png, the view that follows the
map: render_rviz_snapshot.sh --up).
Prints each check; exit 1 if any fails.

usage: check_demo_summary.py OUT_DIR --keyframes N --min_within_1 P --min_within_5 P
                             --min_map_points N --min_on_surface P [--picture] [--follow_picture]
"""
import argparse
import json
import os
import sys

import cv2
import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "scripts"))
from demo_outputs import read_ply  # noqa: E402


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("out_dir")
    parser.add_argument("--keyframes", type=int, required=True, help="depth maps expected (exactly)")
    parser.add_argument("--min_within_1", type=float, required=True, help="percent of pixels within 1 %%")
    parser.add_argument("--min_within_5", type=float, required=True, help="percent of pixels within 5 %%")
    parser.add_argument("--min_map_points", type=int, required=True)
    parser.add_argument("--min_on_surface", type=float, required=True, help="percent of map points within 2 cm")
    parser.add_argument("--picture", action="store_true", help="also check map_rviz.png")
    parser.add_argument("--follow_picture", action="store_true", help="also check map_follow_rviz.png")
    args = parser.parse_args()

    with open(os.path.join(args.out_dir, "summary.json")) as f:
        s = json.load(f)
    within = s["depth_within_percent"]
    xyz, _ = read_ply(s["map_ply"])
    depth_images = sorted(os.listdir(s["depth_images"]))
    checks = [
        ("run completed", s["completed"], True),
        ("keyframes processed", s["keyframes_processed"], args.keyframes),
        ("nothing dropped", s["dropped"], {}),
        ("depth within 1 % >= floor", within["1%"] >= args.min_within_1, f"{within['1%']:.2f} >= {args.min_within_1}"),
        ("depth within 5 % >= floor", within["5%"] >= args.min_within_5, f"{within['5%']:.2f} >= {args.min_within_5}"),
        ("map points >= floor", s["map_points"] >= args.min_map_points, f"{s['map_points']} >= {args.min_map_points}"),
        ("map PLY holds the reported points", len(xyz), s["map_points"]),
        ("map points on the true surface >= floor", s["map_points_within_2cm_percent"] >= args.min_on_surface,
         f"{s['map_points_within_2cm_percent']:.2f} >= {args.min_on_surface}"),
        ("a depth image per keyframe", len(depth_images), args.keyframes),
        ("ms per keyframe measured", s["wall_ms_per_keyframe"] is not None and s["wall_ms_per_keyframe"] > 0, True),
    ]
    # An empty grid (the view away from the map) has about 800 colours.
    for wanted, name in ((args.picture, "map_rviz.png"), (args.follow_picture, "map_follow_rviz.png")):
        if wanted:
            picture = cv2.imread(os.path.join(args.out_dir, name))
            colours = 0 if picture is None else len(np.unique(picture.reshape(-1, 3), axis=0))
            checks.append((f"{name} with > 1000 colours", colours > 1000, f"{colours} colours"))
    failed = 0
    for name, value, expected in checks:
        ok = value is True if isinstance(expected, str) else value == expected
        failed += not ok
        shown = expected if isinstance(expected, str) else f"{value} (expected {expected})"
        print(f"{'ok  ' if ok else 'FAIL'} {name}: {shown}")
    print(f"demo checks: {len(checks) - failed} passed, {failed} failed")
    sys.exit(1 if failed else 0)


if __name__ == "__main__":
    main()
