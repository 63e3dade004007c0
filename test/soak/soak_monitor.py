#!/usr/bin/env python3
"""The soak's monitor (soak.launch). It plays the SLAM system: each played
frame (image, camera info, pose) becomes an amhmvs_mapping/Keyframe with its
own increasing id, so that it knows every keyframe's id and pose; every
repose_every_s it sends a loop-closure update of the 100 newest keyframes
(their pose moved 5 mm); every reset_every_s a ~reset. Every 10 s of wall
time a row of the nodelet's diagnostics and its resident memory goes to
OUT/soak.csv; after `minutes` a summary
(OUT/summary.txt: memory and per-keyframe time after warm-up, the store and
map against their bounds) and the end of the launch."""
import collections
import copy
import csv
import os
import statistics
import sys
import threading
import time
import rospy
from diagnostic_msgs.msg import DiagnosticArray
import message_filters
from geometry_msgs.msg import PoseStamped
from sensor_msgs.msg import CameraInfo, Image
from std_srvs.srv import Trigger

from amhmvs_mapping.msg import Keyframe, KeyframePose, KeyframePoses

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), '..', 'ros'))
from node_watch import rss_mb  # noqa: E402 (beside the rostests' checkers)

COLUMNS = ['wall_s', 'rss_mb', 'keyframes_received', 'depth_maps', 'stored_keyframes', 'map voxels', 'queued',
           'dropped', 'clock_jumps_back', 'pose_updates_applied', 'pose_updates_not_stored', 'resets',
           'last keyframe ms', 'map_memory_mib', 'map_points_kept', 'surface_blocks', 'map_keyframes_frozen']
DIAGNOSTICS_AT_END = COLUMNS[13:]  # straight from the diagnostics, after the derived columns
REPOSED = 100  # keyframes moved by each update: more than the store keeps (store/max_keyframes 50)
WARM_UP_S = 300  # memory and times are compared after the first five minutes


class Monitor:
    def __init__(self):
        self.node = rospy.get_param('~node')
        self.out = rospy.get_param('~out')
        self.minutes = float(rospy.get_param('~minutes'))
        self.reset_every = float(rospy.get_param('~reset_every_s'))
        self.repose_every = float(rospy.get_param('~repose_every_s'))
        self.diagnostics = {}
        self.resets = 0
        self.next_id = 0
        self.sent = collections.OrderedDict()  # keyframe id -> pose, the newest REPOSED
        self.sent_lock = threading.Lock()  # on_frame runs in a subscriber's thread
        ns = self.node.rsplit('/', 1)[0]
        self.keyframe_pub = rospy.Publisher('/keyframe', Keyframe, queue_size=20)
        self.pose_pub = rospy.Publisher(ns + '/keyframe_poses', KeyframePoses, queue_size=5)
        rospy.Subscriber('/diagnostics', DiagnosticArray, self.on_diagnostics)
        frame = message_filters.TimeSynchronizer(
            [message_filters.Subscriber(t, m) for t, m in (('/camera/image_raw', Image),
                                                          ('/camera/camera_info', CameraInfo),
                                                          ('/camera/pose', PoseStamped))], 30)
        frame.registerCallback(self.on_frame)

    def on_frame(self, image, info, pose):
        msg = Keyframe(header=pose.header, keyframe_id=self.next_id, image=image, camera_info=info,
                       camera_to_world=pose.pose)
        with self.sent_lock:
            self.sent[self.next_id] = pose.pose
            while len(self.sent) > REPOSED:
                self.sent.popitem(last=False)
        self.next_id += 1
        self.keyframe_pub.publish(msg)

    def on_diagnostics(self, msg):
        for status in msg.status:
            if 'depth estimation' in status.name:
                self.diagnostics = {kv.key: kv.value for kv in status.values}

    def value(self, key):
        try:
            return float(self.diagnostics.get(key, 'nan'))
        except ValueError:
            return float('nan')

    def repose(self):
        # As a bundle adjustment after a loop closure would: every recent
        # keyframe moves (5 mm from its sent pose); those still stored count as
        # applied, the queued, skipped and evicted ones as not stored.
        update = KeyframePoses()
        update.header.frame_id = 'world'
        with self.sent_lock:
            sent = list(self.sent.items())
        for kf_id, sent_pose in sent:
            pose = KeyframePose(keyframe_id=kf_id, camera_to_world=copy.deepcopy(sent_pose))
            pose.camera_to_world.position.x += 0.005
            update.poses.append(pose)
        if update.poses:
            self.pose_pub.publish(update)

    def reset(self):
        rospy.wait_for_service(self.node + '/reset', timeout=10)
        rospy.ServiceProxy(self.node + '/reset', Trigger)()
        self.resets += 1

    def run(self):
        os.makedirs(self.out, exist_ok=True)
        rows = []
        start = time.time()
        next_sample = next_repose = start
        next_reset = start + self.reset_every
        with open(os.path.join(self.out, 'soak.csv'), 'w', newline='') as f:
            writer = csv.writer(f)
            writer.writerow(COLUMNS)
            while not rospy.is_shutdown() and time.time() - start < 60 * self.minutes:
                now = time.time()
                if now >= next_sample and self.diagnostics:
                    row = [round(now - start, 1), round(rss_mb(self.node), 1)] + \
                          [self.value(k) for k in COLUMNS[2:7]] + \
                          [sum(float(v) for k, v in self.diagnostics.items() if k.startswith('dropped: '))] + \
                          [self.value(k) for k in COLUMNS[8:11]] + [self.resets, self.value('last keyframe ms')] + \
                          [self.value(k) for k in DIAGNOSTICS_AT_END]
                    writer.writerow(row)
                    f.flush()
                    rows.append(dict(zip(COLUMNS, row)))
                    next_sample += 10
                if now >= next_repose:
                    self.repose()
                    next_repose += self.repose_every
                if now >= next_reset:
                    self.reset()
                    next_reset += self.reset_every
                time.sleep(0.2)
        self.summarise(rows)
        rospy.signal_shutdown('soak done')

    def summarise(self, rows):
        late = [r for r in rows if r['wall_s'] >= WARM_UP_S]
        if not late:
            print('soak_monitor: too short for a summary (warm-up %d s)' % WARM_UP_S)
            return
        first, last = late[0], late[-1]
        # Each ~reset starts the maps again: memory is flat when every reset
        # cycle peaks at the same size (the allocator keeps what it had, so the
        # resident size does not drop at a reset).
        cycles = {}
        for r in rows:
            cycles.setdefault(int(r['resets']), []).append(r)
        cycle_lines = ['cycle %d (%.0f-%.0f s): peak memory %.0f MB, maps %.0f MiB, %d voxels, %d surface blocks, '
                       'kept points %d, median keyframe %.0f ms' % (
                           k, c[0]['wall_s'], c[-1]['wall_s'], max(r['rss_mb'] for r in c),
                           max(r['map_memory_mib'] for r in c), max(r['map voxels'] for r in c),
                           max(r['surface_blocks'] for r in c), max(r['map_points_kept'] for r in c),
                           statistics.median(r['last keyframe ms'] for r in c))
                       for k, c in sorted(cycles.items())]
        hours = (last['wall_s'] - first['wall_s']) / 3600
        quarter = max(1, len(late) // 4)
        lines = [
            'soak: %.1f min, %d resets, %d clock jumps back (bag loops)' % (
                rows[-1]['wall_s'] / 60, self.resets, last['clock_jumps_back']),
            'resident memory after warm-up: %.0f MB at %.0f s, %.0f MB at the end, at most %.0f MB' % (
                first['rss_mb'], first['wall_s'], last['rss_mb'], max(r['rss_mb'] for r in late)),
            'memory growth after warm-up: %.1f MB per hour' % (
                (last['rss_mb'] - first['rss_mb']) / hours if hours > 0 else float('nan')),
            'last keyframe ms, median of the first / last quarter after warm-up: %.1f / %.1f' % (
                statistics.median(r['last keyframe ms'] for r in late[:quarter]),
                statistics.median(r['last keyframe ms'] for r in late[-quarter:])),
            'most stored keyframes %d (bound %d); most map voxels %d (bound %d)' % (
                max(r['stored_keyframes'] for r in rows), rospy.get_param(self.node + '/store/max_keyframes'),
                max(r['map voxels'] for r in rows), rospy.get_param(self.node + '/map/max_voxels')),
            'pose updates applied %d, not stored %d; dropped in all %d; map keyframes frozen %d' % (
                last['pose_updates_applied'], last['pose_updates_not_stored'], last['dropped'],
                last['map_keyframes_frozen']),
        ] + cycle_lines
        with open(os.path.join(self.out, 'summary.txt'), 'w') as f:
            f.write('\n'.join(lines) + '\n')
        print('\n'.join(lines))


if __name__ == '__main__':
    rospy.init_node('soak_monitor')
    Monitor().run()
    sys.exit(0)
