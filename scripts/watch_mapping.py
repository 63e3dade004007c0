#!/usr/bin/env python3
"""Watches the mapping nodelet while a bag plays (scripts/bag_at_rate.sh):
the bag's frames, each depth image and map publication against wall time, and
the diagnostics' counters. Writes OUT.json when the nodelet reports
'input ended, idle' or after TIMEOUT seconds.

  watch_mapping.py OUT.json [TIMEOUT]"""
import json
import os
import sys
import time

import rospy
from diagnostic_msgs.msg import DiagnosticArray
from sensor_msgs.msg import Image, PointCloud2


def main():
    out = sys.argv[1]
    timeout = float(sys.argv[2]) if len(sys.argv) > 2 else 300.0
    rospy.init_node('watch_mapping')
    events, status = [], {}

    def record(kind, value):
        events.append((kind, time.time(), value))

    def on_diagnostics(message):
        for entry in message.status:
            if entry.name.endswith('depth estimation'):
                status.clear()
                status.update({kv.key: kv.value for kv in entry.values})
                status['summary'] = entry.message

    rospy.Subscriber('/camera/image_raw', Image, lambda m: record('frame', m.header.stamp.to_sec()), queue_size=100)
    rospy.Subscriber('/amhmvs/depth/image', Image, lambda m: record('depth', m.header.stamp.to_sec()), queue_size=100)
    rospy.Subscriber('/amhmvs/map', PointCloud2, lambda m: record('map', m.width * m.height), queue_size=10)
    rospy.Subscriber('/diagnostics', DiagnosticArray, on_diagnostics, queue_size=10)
    start = time.time()
    while not rospy.is_shutdown() and time.time() - start < timeout:
        time.sleep(0.5)
        if status.get('summary', '').startswith('input ended, idle'):
            break
    frames = [e[1] for e in events if e[0] == 'frame']
    depth = [e[1] for e in events if e[0] == 'depth']
    played = (frames[0], frames[-1]) if frames else (start, start)
    during = [t for t in depth if t <= played[1]]
    summary = {'frames': len(frames), 'bag_wall_s': played[1] - played[0], 'depth_images': len(depth),
               'depth_images_while_playing': len(during),
               'depth_per_s_while_playing': len(during) / max(played[1] - played[0], 1e-9),
               'map_voxels': status.get('map voxels'), 'status': status.get('summary')}
    with open(out + '.tmp', 'w') as f:
        json.dump({'summary': summary, 'events': events, 'last_status': status}, f)
    os.replace(out + '.tmp', out)
    print(' '.join('%s=%s' % (k, round(v, 2) if isinstance(v, float) else v) for k, v in summary.items()))


if __name__ == '__main__':
    main()
