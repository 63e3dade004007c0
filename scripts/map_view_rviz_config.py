#!/usr/bin/env python3
"""Writes a copy of an rviz config whose 3D view follows a saved map: the
fixed frame is world_view (published by publish_ply.py at the map's median
point, z up), the orbit view looks at its origin from a distance that fits
most of the map, at the shipped config's angles unless AMHMVS_VIEW_YAW /
AMHMVS_VIEW_PITCH (radians) say otherwise. The shipped config stays the one
source of displays.

usage: map_view_rviz_config.py IN.rviz OUT.rviz MAP.ply
"""
import os
import sys

import numpy as np
import yaml

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from demo_outputs import read_ply  # noqa: E402

# Far enough that 80 % of the points (their distance from the median) fit
# rviz's default field of view, looking down at the pitch of the shipped config.
FIT = 3.5


def main():
    if len(sys.argv) != 4:
        sys.exit(__doc__)
    xyz, _ = read_ply(sys.argv[3])
    radius = float(np.percentile(np.linalg.norm(xyz - np.median(xyz, axis=0), axis=1), 80)) if len(xyz) else 1.0
    with open(sys.argv[1]) as f:
        config = yaml.safe_load(f)
    manager = config.setdefault("Visualization Manager", {})
    manager.setdefault("Global Options", {})["Fixed Frame"] = "world_view"
    for display in manager.get("Displays", []):
        if display.get("Class") == "rviz/Grid":  # centred under the map
            display["Offset"] = {"X": 0.0, "Y": 0.0, "Z": 0.0}
    manager.setdefault("Views", {})["Current"] = {
        "Class": "rviz/Orbit", "Distance": max(0.5, FIT * radius), "Focal Point": {"X": 0.0, "Y": 0.0, "Z": 0.0},
        "Pitch": float(os.environ.get("AMHMVS_VIEW_PITCH", 0.6)), "Yaw": float(os.environ.get("AMHMVS_VIEW_YAW", 0.8)), "Name": "Current View", "Target Frame": "<Fixed Frame>", "Value": "Orbit (rviz)"}
    with open(sys.argv[2], "w") as f:
        yaml.safe_dump(config, f, sort_keys=False)


if __name__ == "__main__":
    main()
