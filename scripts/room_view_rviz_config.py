#!/usr/bin/env python3
"""Writes a copy of an rviz config whose 3D view looks at the demo's synthetic
room (x 0..6, y 0..5 m, from above the camera path): the shipped config stays
the one source of displays, the demo only moves the camera (into the room's
own z-up world frame).

usage: room_view_rviz_config.py IN.rviz OUT.rviz
"""
import sys

import yaml

ROOM_VIEW = {"Class": "rviz/Orbit", "Distance": 7.5, "Focal Point": {"X": 3.2, "Y": 2.5, "Z": 0.4},
             "Pitch": 0.75, "Yaw": 3.3, "Name": "Current View", "Target Frame": "<Fixed Frame>",
             "Value": "Orbit (rviz)"}


def main():
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    with open(sys.argv[1]) as f:
        config = yaml.safe_load(f)
    manager = config.setdefault("Visualization Manager", {})
    manager.setdefault("Global Options", {})["Fixed Frame"] = "world"
    manager.setdefault("Views", {})["Current"] = ROOM_VIEW
    with open(sys.argv[2], "w") as f:
        yaml.safe_dump(config, f, sort_keys=False)


if __name__ == "__main__":
    main()
