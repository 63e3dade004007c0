#!/usr/bin/env python3
"""Demo monitor: watches the mapping nodelet's outputs while a bag with
ground-truth depth plays, prints one progress line per keyframe, and at the
end writes the map (PLY), colour-mapped depth images and a summary.

Subscribes (remap as needed):
  depth, depth_camera_info  the nodelet's depth/image (32FC1) and its camera_info
  keyframe_cloud            the nodelet's keyframe clouds (optical frame)
  depth_gt                  ground-truth depth of the input images (32FC1, same stamps)
  diagnostics               the nodelet's counters (the end condition)
  /tf                       camera poses, to move the keyframe clouds into ~fixed_frame
  map (if ~map_topic)       a global map PointCloud2 in ~fixed_frame; when one
                            arrives, map.ply is written from the latest one instead
                            of from the accumulated keyframe clouds
Parameters:
  ~output_dir       where map.ply, depth/, summary.txt and summary.json go
  ~expected_frames  frames in the bag: the run ends once the nodelet has accounted
                    for all of them (depth map, no source, not a keyframe, dropped)
  ~timeout          wall seconds before giving up (exit 1), default 900
  ~fixed_frame      default world
  ~map_topic        default "" (accumulate keyframe clouds)
  ~stay_while_node  default "": after the summary, keep running (and so keep the
                    launch up, this node being required) until this node ends,
                    e.g. /rviz: the user closes rviz to end the demo
"""
import contextlib
import io
import json
import os
import sys
import threading
import time

import numpy as np
import rosnode
import rospy
import tf2_ros
from diagnostic_msgs.msg import DiagnosticArray
from sensor_msgs.msg import CameraInfo, Image, PointCloud2

from demo_outputs import colour_depth_pair, write_ply

THRESHOLDS = (0.01, 0.02, 0.05)      # relative depth error, as amhmvs_depth --ground_truth
SURFACE_TOLERANCE = 0.02             # metres, map points "on the true surface"
FIELD_DTYPES = {7: "<f4", 8: "<f8"}  # PointField datatypes the clouds use


def depth_array(msg):
    if msg.encoding != "32FC1":
        raise ValueError(f"depth encoding {msg.encoding}, expected 32FC1")
    rows = np.frombuffer(msg.data, dtype=">f4" if msg.is_bigendian else "<f4", count=msg.height * msg.step // 4)
    return rows.reshape(msg.height, msg.step // 4)[:, :msg.width]


def cloud_arrays(msg):
    """(N x 3 float64 xyz, N x 3 uint8 rgb) of a PointCloud2 with x y z rgb fields."""
    fields = {f.name: f for f in msg.fields}
    dtype = np.dtype({"names": ["x", "y", "z", "rgb"],
                      "formats": [FIELD_DTYPES[fields[n].datatype] if n != "rgb" else "<u4" for n in "x y z rgb".split()],
                      "offsets": [fields[n].offset for n in ("x", "y", "z", "rgb")],
                      "itemsize": msg.point_step})
    points = np.frombuffer(msg.data, dtype=dtype, count=msg.width * msg.height)
    xyz = np.stack([points["x"], points["y"], points["z"]], axis=1).astype(np.float64)
    packed = points["rgb"]
    rgb = np.stack([(packed >> 16) & 255, (packed >> 8) & 255, packed & 255], axis=1).astype(np.uint8)
    keep = np.isfinite(xyz).all(axis=1)
    return xyz[keep], rgb[keep]


def stamp_key(stamp):
    return (stamp.secs, stamp.nsecs)


def seconds(key):
    return key[0] + 1e-9 * key[1]


def rigid_matrix(transform):
    t, q = transform.translation, transform.rotation
    x, y, z, w = q.x, q.y, q.z, q.w
    rotation = np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                         [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                         [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])
    return rotation, np.array([t.x, t.y, t.z])


class DemoMonitor:
    def __init__(self):
        self.output_dir = rospy.get_param("~output_dir")
        self.expected_frames = int(rospy.get_param("~expected_frames"))
        self.timeout = float(rospy.get_param("~timeout", 900.0))
        self.fixed_frame = rospy.get_param("~fixed_frame", "world")
        map_topic = rospy.get_param("~map_topic", "")
        os.makedirs(os.path.join(self.output_dir, "depth"), exist_ok=True)

        self.lock = threading.Lock()
        self.ground_truth = {}      # stamp -> depth array
        self.depth = {}             # stamp -> (depth array, wall ms since the previous one), until evaluated
        self.camera_info = {}       # stamp -> CameraInfo of the depth image
        self.pending_clouds = []    # clouds waiting for their tf, ground truth and camera_info
        self.evaluated = []         # per keyframe: stamp, counts, total
        self.progress = {}          # stamp -> progress line waiting for the keyframe's cloud
        self.mapped = set()         # stamps of the clouds in the map
        self.cloud_xyz, self.cloud_rgb = [], []
        self.cloud_points_on_surface = 0
        self.cloud_points_checked = 0
        self.latest_map = None
        self.diagnostics = {}
        self.estimate_ms = {}       # depth map count -> "last estimate ms" seen with it
        self.depth_count = self.cloud_count = 0
        self.start = time.monotonic()
        self.first_stamp = None
        self.last_depth_time = None

        self.tf_buffer = tf2_ros.Buffer(cache_time=rospy.Duration(3600))
        self.tf_listener = tf2_ros.TransformListener(self.tf_buffer)
        # The ground truth last: rosbag play --wait-for-subscribers starts once
        # every bag topic has a subscriber, and by then the outputs have theirs.
        rospy.Subscriber("diagnostics", DiagnosticArray, self.on_diagnostics, queue_size=20)
        rospy.Subscriber("depth_camera_info", CameraInfo, self.on_camera_info, queue_size=100)
        rospy.Subscriber("depth", Image, self.on_depth, queue_size=100, buff_size=2 ** 24)
        rospy.Subscriber("keyframe_cloud", PointCloud2, self.on_cloud, queue_size=100, buff_size=2 ** 26)
        if map_topic:
            rospy.Subscriber(map_topic, PointCloud2, self.on_map, queue_size=1, buff_size=2 ** 28)
        rospy.Subscriber("depth_gt", Image, self.on_ground_truth, queue_size=1000, buff_size=2 ** 24)

    # ------------------------------------------------------------ callbacks --
    def on_ground_truth(self, msg):
        with self.lock:
            if self.first_stamp is None:
                self.first_stamp = seconds(stamp_key(msg.header.stamp))
            self.ground_truth[stamp_key(msg.header.stamp)] = depth_array(msg).copy()
            self.evaluate_ready()

    def on_camera_info(self, msg):
        with self.lock:
            self.camera_info[stamp_key(msg.header.stamp)] = msg

    def on_depth(self, msg):
        now = time.monotonic()
        with self.lock:
            self.depth_count += 1
            wall_ms = 1000.0 * (now - (self.last_depth_time or self.start))
            self.last_depth_time = now
            self.depth[stamp_key(msg.header.stamp)] = (depth_array(msg).copy(), wall_ms)
            self.evaluate_ready()

    def on_cloud(self, msg):
        with self.lock:
            self.cloud_count += 1
            self.pending_clouds.append(msg)
            self.transform_ready_clouds()

    def on_map(self, msg):
        with self.lock:
            self.latest_map = msg

    def on_diagnostics(self, msg):
        for status in msg.status:
            if not status.name.endswith("depth estimation"):
                continue
            values = {v.key: v.value for v in status.values}
            with self.lock:
                self.diagnostics = values
                maps = int(values.get("depth_maps", 0))
                if maps > 0 and "last estimate ms" in values:
                    self.estimate_ms.setdefault(maps, float(values["last estimate ms"]))

    # ----------------------------------------------------------- evaluation --
    def evaluate_ready(self):
        for stamp in [s for s in self.depth if s in self.ground_truth]:
            estimate, wall_ms = self.depth.pop(stamp)
            truth = self.ground_truth[stamp]
            if truth.shape != estimate.shape:  # depth downscaled by ~max_image_size
                rows = ((np.arange(estimate.shape[0]) + 0.5) * truth.shape[0] / estimate.shape[0]).astype(int)
                cols = ((np.arange(estimate.shape[1]) + 0.5) * truth.shape[1] / estimate.shape[1]).astype(int)
                truth = truth[np.ix_(rows, cols)]
            valid = np.isfinite(truth) & (truth > 0)
            with np.errstate(invalid="ignore"):
                error = np.abs(estimate[valid] - truth[valid]) / truth[valid]
            within = [int(np.count_nonzero(error < t)) for t in THRESHOLDS]  # NaN counts as wrong
            total = int(np.count_nonzero(valid))
            index = len(self.evaluated) + 1
            self.evaluated.append({"stamp": seconds(stamp), "within": within, "total": total, "wall_ms": wall_ms})
            colour_depth_pair(estimate, truth, os.path.join(self.output_dir, "depth", f"{index:04d}.png"))
            self.progress[stamp] = (f"keyframe {index} (t={seconds(stamp) - self.first_stamp:.2f} s): "
                                    + " / ".join(f"{100.0 * w / max(total, 1):.1f}" for w in within)
                                    + f" % within 1/2/5 % of ground truth, {wall_ms:.0f} ms")
            self.print_progress()

    def print_progress(self):
        """One line per keyframe once its depth is evaluated and its cloud is in the map."""
        for stamp in [s for s in self.progress if s in self.mapped]:
            print(f"{self.progress.pop(stamp)}, map {sum(len(x) for x in self.cloud_xyz)} points", flush=True)

    def transform_ready_clouds(self):
        waiting = []
        for msg in self.pending_clouds:
            key = stamp_key(msg.header.stamp)
            if key not in self.ground_truth or key not in self.camera_info:  # needed for the surface check
                waiting.append(msg)
                continue
            try:
                transform = self.tf_buffer.lookup_transform(self.fixed_frame, msg.header.frame_id, msg.header.stamp)
            except (tf2_ros.LookupException, tf2_ros.ExtrapolationException, tf2_ros.ConnectivityException):
                waiting.append(msg)
                continue
            xyz, rgb = cloud_arrays(msg)
            self.check_against_ground_truth(xyz, msg)
            rotation, translation = rigid_matrix(transform.transform)
            self.cloud_xyz.append(xyz @ rotation.T + translation)
            self.cloud_rgb.append(rgb)
            self.mapped.add(stamp_key(msg.header.stamp))
        self.pending_clouds = waiting
        self.print_progress()

    def check_against_ground_truth(self, xyz, msg):
        """Points of one keyframe cloud (optical frame) against that keyframe's true depth."""
        key = stamp_key(msg.header.stamp)
        truth, info = self.ground_truth[key], self.camera_info[key]
        if len(xyz) == 0:
            return
        # Intrinsics of the depth image, rescaled to the ground truth's size.
        sx, sy = truth.shape[1] / info.width, truth.shape[0] / info.height
        fx, fy, cx, cy = info.K[0] * sx, info.K[4] * sy, (info.K[2] + 0.5) * sx - 0.5, (info.K[5] + 0.5) * sy - 0.5
        z = xyz[:, 2]
        u = np.rint(fx * xyz[:, 0] / z + cx).astype(int)
        v = np.rint(fy * xyz[:, 1] / z + cy).astype(int)
        inside = (z > 0) & (u >= 0) & (u < truth.shape[1]) & (v >= 0) & (v < truth.shape[0])
        true_z = truth[v[inside], u[inside]]
        checked = np.isfinite(true_z)
        self.cloud_points_checked += int(np.count_nonzero(checked))
        self.cloud_points_on_surface += int(np.count_nonzero(np.abs(z[inside][checked] - true_z[checked]) < SURFACE_TOLERANCE))

    # ------------------------------------------------------------ end state --
    def accounted_frames(self):
        """Frames the nodelet has finished with, from its diagnostics counters."""
        d = self.diagnostics
        dropped = sum(int(value) for key, value in d.items() if key.startswith("dropped: "))
        return (int(d.get("depth_maps", 0)) + int(d.get("keyframes_without_sources", 0)) +
                int(d.get("frames_not_keyframes", 0)) + dropped)

    def finished(self):
        with self.lock:
            if not self.diagnostics or int(self.diagnostics.get("queued", 1)) != 0:
                return False
            maps = int(self.diagnostics.get("depth_maps", 0))
            self.transform_ready_clouds()
            return (self.accounted_frames() >= self.expected_frames and self.depth_count >= maps and
                    self.cloud_count >= maps and not self.depth and not self.pending_clouds)

    def summary(self, completed):
        within = np.sum([k["within"] for k in self.evaluated], axis=0) if self.evaluated else np.zeros(3)
        total = sum(k["total"] for k in self.evaluated)
        if self.latest_map is not None:
            xyz, rgb = cloud_arrays(self.latest_map)
            map_source = f"global map topic ({self.latest_map.header.frame_id})"
        else:
            xyz = np.concatenate(self.cloud_xyz) if self.cloud_xyz else np.zeros((0, 3))
            rgb = np.concatenate(self.cloud_rgb) if self.cloud_rgb else np.zeros((0, 3), np.uint8)
            map_source = f"keyframe clouds in {self.fixed_frame}"
        map_path = os.path.join(self.output_dir, "map.ply")
        write_ply(map_path, xyz, rgb)
        d = self.diagnostics
        dropped = {k[len("dropped: "):]: int(v) for k, v in d.items() if k.startswith("dropped: ")}
        wall = [k["wall_ms"] for k in self.evaluated]
        return {
            "completed": completed,
            "backend": d.get("backend", "unknown"),
            "frames": self.expected_frames,
            "keyframes_processed": len(self.evaluated),
            "keyframes_without_sources": int(d.get("keyframes_without_sources", 0)),
            "dropped": dropped,
            "estimate_ms_per_keyframe": float(np.mean(list(self.estimate_ms.values()))) if self.estimate_ms else None,
            "estimate_ms_samples": len(self.estimate_ms),
            "wall_ms_per_keyframe": float(np.mean(wall)) if wall else None,
            "depth_within_percent": {f"{100 * t:g}%": 100.0 * w / max(total, 1) for t, w in zip(THRESHOLDS, within)},
            "depth_pixels_evaluated": total,
            "map_points": int(len(xyz)),
            "map_source": map_source,
            "map_points_within_2cm_percent": 100.0 * self.cloud_points_on_surface / max(self.cloud_points_checked, 1),
            "map_ply": map_path,
            "depth_images": os.path.join(self.output_dir, "depth"),
            "run_seconds": time.monotonic() - self.start,
        }


def summary_text(s):
    ms = lambda v: "n/a" if v is None else f"{v:.0f} ms"
    within = " / ".join(f"{v:.1f}" for v in s["depth_within_percent"].values())
    return "\n".join([
        "== amhmvs demo summary ==" + ("" if s["completed"] else " (TIMED OUT: incomplete)"),
        f"keyframes processed:  {s['keyframes_processed']} depth maps from {s['frames']} frames "
        f"({s['keyframes_without_sources']} without source views, dropped: {s['dropped'] or 'none'}), backend {s['backend']}",
        f"time per keyframe:    {ms(s['estimate_ms_per_keyframe'])} estimation (nodelet, {s['estimate_ms_samples']} sampled), "
        f"{ms(s['wall_ms_per_keyframe'])} wall",
        f"depth accuracy:       {within} % of {s['depth_pixels_evaluated']} ground-truth pixels within 1 / 2 / 5 % "
        "(no estimate counts as wrong)",
        f"map:                  {s['map_points']} points ({s['map_source']}), "
        f"{s['map_points_within_2cm_percent']:.1f} % within 2 cm of the true surface",
        f"map PLY:              {s['map_ply']}",
        f"depth images:         {s['depth_images']}/NNNN.png (estimate | ground truth, same colour scale)",
    ])


def node_alive(name):
    """The node answers (a killed node can stay registered with the master)."""
    with contextlib.redirect_stdout(io.StringIO()):  # rosnode_ping reports on stdout
        return rosnode.rosnode_ping(name, max_count=1, verbose=False)


def main():
    rospy.init_node("demo_monitor")
    monitor = DemoMonitor()
    deadline = time.monotonic() + monitor.timeout
    completed = False
    while not rospy.is_shutdown() and time.monotonic() < deadline:
        if monitor.finished():
            completed = True
            break
        time.sleep(0.2)  # polls the end condition; callbacks run on their own threads
    if not completed and not rospy.is_shutdown():
        rospy.logerr("demo monitor: gave up after %.0f s; nodelet diagnostics: %s", monitor.timeout, monitor.diagnostics)
    with monitor.lock:
        summary = monitor.summary(completed)
    text = summary_text(summary)
    print("\n" + text, flush=True)
    with open(os.path.join(monitor.output_dir, "summary.txt"), "w") as f:
        f.write(text + "\n")
    with open(os.path.join(monitor.output_dir, "summary.json"), "w") as f:
        json.dump(summary, f, indent=2)
    stay_while = rospy.get_param("~stay_while_node", "")
    if stay_while and completed:
        print(f"{stay_while} stays open: close it to end the demo", flush=True)
        while not rospy.is_shutdown() and node_alive(stay_while):
            time.sleep(1.0)
    sys.exit(0 if completed else 1)


if __name__ == "__main__":
    main()
