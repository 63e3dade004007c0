#!/usr/bin/env python3
"""Republishes geometry_msgs/PoseStamped (~input, e.g. a bag's /camera/pose)
as nav_msgs/Odometry (~output) with the same header, to drive the mapping
nodelet's odometry input mode from the test bags."""
import rospy
from geometry_msgs.msg import PoseStamped
from nav_msgs.msg import Odometry


def main():
    rospy.init_node('pose_to_odometry')
    publisher = rospy.Publisher(rospy.get_param('~output', '/odom'), Odometry, queue_size=20)

    def relay(pose):
        odometry = Odometry()
        odometry.header = pose.header
        odometry.child_frame_id = rospy.get_param('~child_frame', 'camera_optical')
        odometry.pose.pose = pose.pose
        publisher.publish(odometry)
    rospy.Subscriber(rospy.get_param('~input', '/camera/pose'), PoseStamped, relay, queue_size=20)
    rospy.spin()


if __name__ == '__main__':
    main()
