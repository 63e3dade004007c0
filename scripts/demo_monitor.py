#!/usr/bin/env python3
"""Demo monitor: watches the mapping nodelet's outputs while a bag with
ground-truth depth plays, prints one progress line per keyframe, and at the
end has the nodelet save its global map (map.ply, via its save_map service),
checks the map against the ground truth and writes colour-mapped depth images
and a summary. The map is judged through the bag's poses (/tf): right for
sequences whose poses are the truth; for a realism-mode sequence (tracker
poses apart from the true ones) amhmvs_map reports against the true surface.

Subscribes and calls (remap as needed):
  depth, depth_camera_info  the nodelet's depth/image (32FC1) and its camera_info
  depth_gt                  ground-truth depth of the input images (32FC1, same stamps)
  diagnostics               the nodelet's counters (the end condition, map size)
  /tf                       camera poses in ~fixed_frame, to check the map points
  save_map                  the nodelet's ~save_map service (amhmvs_mapping/SaveMap)
Parameters:
  ~output_dir       where map.ply, depth/, summary.txt and summary.json go
  ~expected_frames  frames in the bag: the run ends once the nodelet has received
                    all of them and is idle (every depth map out, late ones
                    included); keyframes the nodelet has not fused into the
                    map by then are not waited for
  ~timeout          wall seconds before giving up (exit 1), default 900
  ~fixed_frame      default world
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
from sensor_msgs.msg import CameraInfo, Image

from amhmvs_mapping.srv import SaveMap
# In the devel space catkin runs this file through a relay script in another
# folder: demo_outputs is found next to this file (installed: the same folder).
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from demo_outputs import colour_depth_pair, read_ply
from dense_folder_to_bag import quaternion_matrix

THRESHOLDS = (0.01, 0.02, 0.05)      # relative depth error, as amhmvs_depth --ground_truth
SURFACE_TOLERANCE = 0.02             # metres, map points "on the true surface"


def depth_array(msg):
    if msg.encoding != "32FC1":
        raise ValueError(f"depth encoding {msg.encoding}, expected 32FC1")
    rows = np.frombuffer(msg.data, dtype=">f4" if msg.is_bigendian else "<f4", count=msg.height * msg.step // 4)
    return rows.reshape(msg.height, msg.step // 4)[:, :msg.width]


def stamp_key(stamp):
    return (stamp.secs, stamp.nsecs)


def seconds(key):
    return key[0] + 1e-9 * key[1]


def rigid_matrix(transform):
    t = transform.translation
    return np.array(quaternion_matrix(transform.rotation)), np.array([t.x, t.y, t.z])


def surface_errors(xyz, truth, info, rotation, translation):
    """|depth - true depth| in metres of world points seen by one camera
    (rotation, translation: camera-to-world), inf where the camera has no true
    depth for them. The true depth is interpolated bilinearly in inverse depth
    (exact on planes) from the four ground-truth pixels around the projection."""
    # Intrinsics of the depth image, rescaled to the ground truth's size.
    sx, sy = truth.shape[1] / info.width, truth.shape[0] / info.height
    fx, fy, cx, cy = info.K[0] * sx, info.K[4] * sy, (info.K[2] + 0.5) * sx - 0.5, (info.K[5] + 0.5) * sy - 0.5
    camera = (xyz - translation) @ rotation
    z = camera[:, 2]
    errors = np.full(len(xyz), np.inf)
    with np.errstate(divide="ignore", invalid="ignore"):
        u, v = fx * camera[:, 0] / z + cx, fy * camera[:, 1] / z + cy
    inside = (z > 0) & (u >= 0) & (u <= truth.shape[1] - 1) & (v >= 0) & (v <= truth.shape[0] - 1)
    u, v, z, index = u[inside], v[inside], z[inside], np.flatnonzero(inside)
    u0 = np.minimum(u.astype(int), truth.shape[1] - 2)
    v0 = np.minimum(v.astype(int), truth.shape[0] - 2)
    a, b = u - u0, v - v0
    inverse = 1.0 / truth  # NaN (no surface) stays NaN
    true_inverse = ((1 - a) * (1 - b) * inverse[v0, u0] + a * (1 - b) * inverse[v0, u0 + 1] +
                    (1 - a) * b * inverse[v0 + 1, u0] + a * b * inverse[v0 + 1, u0 + 1])
    known = np.isfinite(true_inverse) & (true_inverse > 0)
    errors[index[known]] = np.abs(z[known] - 1.0 / true_inverse[known])
    return errors


class DemoMonitor:
    def __init__(self):
        self.output_dir = rospy.get_param("~output_dir")
        self.expected_frames = int(rospy.get_param("~expected_frames"))
        self.timeout = float(rospy.get_param("~timeout", 900.0))
        self.fixed_frame = rospy.get_param("~fixed_frame", "world")
        os.makedirs(os.path.join(self.output_dir, "depth"), exist_ok=True)

        self.lock = threading.Lock()
        self.ground_truth = {}      # stamp -> depth array
        self.depth = {}             # stamp -> (depth array, wall ms since the previous one), until evaluated
        self.camera_info = {}       # stamp -> CameraInfo of the depth image
        self.evaluated = {}         # stamp -> its latest depth map's stamp, counts, total, index
        self.refined = 0            # depth maps that replaced an earlier one of their keyframe
        self.progress = []          # (depth maps count, line) waiting for diagnostics with that count
        self.diagnostics = {}
        self.estimate_ms = {}       # depth map count -> "last estimate ms" seen with it
        self.depth_count = 0
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
                self.print_progress()

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
            # A refined depth map (the nodelet re-estimated the keyframe with
            # better sources) replaces the earlier one of that keyframe.
            refined = stamp in self.evaluated
            self.refined += refined
            # The nodelet's keyframe id: it numbers keyframes from 0 in arrival
            # order, and every frame of the demo's sequence is a keyframe.
            index = sorted(self.ground_truth).index(stamp)
            self.evaluated[stamp] = {"stamp": seconds(stamp), "within": within, "total": total, "wall_ms": wall_ms,
                                     "index": index}
            colour_depth_pair(estimate, truth, os.path.join(self.output_dir, "depth", f"{index:04d}.png"))
            self.progress.append((index, f"keyframe {index}{' refined' if refined else ''} "
                                  f"(t={seconds(stamp) - self.first_stamp:.2f} s): "
                                  + " / ".join(f"{100.0 * w / max(total, 1):.1f}" for w in within)
                                  + f" % within 1/2/5 % of ground truth, {wall_ms:.0f} ms"))
            self.print_progress()

    def print_progress(self):
        """One line per keyframe once its depth is evaluated and the nodelet's
        diagnostics count its depth map, with the map size they report then."""
        maps = int(self.diagnostics.get("depth_maps", 0))
        while self.progress and self.progress[0][0] <= maps:
            print(f"{self.progress.pop(0)[1]}, map {self.diagnostics.get('map voxels', '?')} voxels", flush=True)

    def map_on_surface(self, xyz):
        """Map points checked (seen with a true depth by a keyframe with a depth
        map) and those within SURFACE_TOLERANCE of the true depth in one of them."""
        best = np.full(len(xyz), np.inf)
        for stamp, info in self.camera_info.items():
            if stamp not in self.ground_truth:
                continue
            try:
                transform = self.tf_buffer.lookup_transform(self.fixed_frame, info.header.frame_id, info.header.stamp)
            except (tf2_ros.LookupException, tf2_ros.ExtrapolationException, tf2_ros.ConnectivityException) as e:
                rospy.logwarn("demo monitor: keyframe at %.2f s not used to check the map: %s", seconds(stamp), e)
                continue
            rotation, translation = rigid_matrix(transform.transform)
            best = np.minimum(best, surface_errors(xyz, self.ground_truth[stamp], info, rotation, translation))
        return int(np.count_nonzero(np.isfinite(best))), int(np.count_nonzero(best < SURFACE_TOLERANCE))

    # ------------------------------------------------------------ end state --
    def finished(self):
        """The nodelet has received every frame, is idle (nothing left to
        estimate, late depth maps included) and each depth map is evaluated
        (whether the nodelet has fused every keyframe into its map is not asked)."""
        with self.lock:
            d = self.diagnostics
            if not d or d.get("idle") != "True":
                return False
            return (int(d.get("frames_received", 0)) >= self.expected_frames and
                    self.depth_count >= int(d.get("depth_maps", 0)) and not self.depth)

    def save_map(self):
        """The nodelet's map written to map.ply by its save_map service: (path, problem or "")."""
        path = os.path.join(self.output_dir, "map.ply")
        try:
            rospy.wait_for_service("save_map", timeout=10.0)
            response = rospy.ServiceProxy("save_map", SaveMap)(path)
        except (rospy.ROSException, rospy.ServiceException) as e:
            return path, f"save_map: {e}"
        return path, "" if response.success else response.message

    def summary(self, completed, map_path, xyz):
        evaluated = list(self.evaluated.values())
        within = np.sum([k["within"] for k in evaluated], axis=0) if evaluated else np.zeros(3)
        total = sum(k["total"] for k in evaluated)
        checked, on_surface = self.map_on_surface(xyz)
        d = self.diagnostics
        dropped = {k[len("dropped: "):]: int(v) for k, v in d.items() if k.startswith("dropped: ") and v != "0"}
        wall = [k["wall_ms"] for k in evaluated]
        return {
            "completed": completed,
            "backend": d.get("backend", "unknown"),
            "frames": self.expected_frames,
            "keyframes_processed": len(self.evaluated),
            "keyframes_late": int(d.get("late_depth_maps", 0)),
            "keyframes_refined": self.refined,
            "keyframes_without_depth": int(d.get("keyframes_waiting_for_sources", 0)),
            "dropped": dropped,
            "estimate_ms_per_keyframe": float(np.mean(list(self.estimate_ms.values()))) if self.estimate_ms else None,
            "estimate_ms_samples": len(self.estimate_ms),
            "wall_ms_per_keyframe": float(np.mean(wall)) if wall else None,
            "depth_within_percent": {f"{100 * t:g}%": 100.0 * w / max(total, 1) for t, w in zip(THRESHOLDS, within)},
            "depth_pixels_evaluated": total,
            "map_points": int(len(xyz)),
            "map_source": f"the nodelet's voxel map, {self.fixed_frame}, saved by save_map",
            "map_points_checked": checked,
            "map_points_within_2cm_percent": 100.0 * on_surface / max(checked, 1),
            "map_ply": map_path,
            "depth_images": os.path.join(self.output_dir, "depth"),
            "run_seconds": time.monotonic() - self.start,
        }


def summary_text(s):
    ms = lambda v: "n/a" if v is None else f"{v:.0f} ms"
    within = " / ".join(f"{v:.1f}" for v in s["depth_within_percent"].values())
    return "\n".join([
        "== amhmvs demo summary ==" + ("" if s["completed"] else " (INCOMPLETE: see the errors above)"),
        f"keyframes processed:  {s['keyframes_processed']} depth maps from {s['frames']} frames "
        f"({s['keyframes_late']} estimated late, {s['keyframes_refined']} refined, "
        f"{s['keyframes_without_depth']} still without source views, "
        f"dropped: {s['dropped'] or 'none'}), backend {s['backend']}",
        f"time per keyframe:    {ms(s['estimate_ms_per_keyframe'])} estimation (nodelet, {s['estimate_ms_samples']} sampled), "
        f"{ms(s['wall_ms_per_keyframe'])} wall",
        f"depth accuracy:       {within} % of {s['depth_pixels_evaluated']} ground-truth pixels within 1 / 2 / 5 % "
        "(no estimate counts as wrong)",
        f"map:                  {s['map_points']} points ({s['map_source']}), "
        f"{s['map_points_within_2cm_percent']:.1f} % of {s['map_points_checked']} checked within 2 cm of the true surface",
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
    map_path, problem = monitor.save_map()
    if problem:
        rospy.logerr("demo monitor: the nodelet did not save its map: %s", problem)
        completed = False
    xyz = np.zeros((0, 3)) if problem else read_ply(map_path)[0]
    with monitor.lock:
        summary = monitor.summary(completed, map_path, xyz)
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
