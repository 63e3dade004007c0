#!/usr/bin/env python3
"""Republishes sensor_msgs/Image (~input, rgb8/bgr8/mono8) as
sensor_msgs/CompressedImage on ~output with the same header, encoded as the
official compressed_image_transport does (format "rgb8; jpeg compressed bgr8",
JPEG ~jpeg_quality or PNG by ~format): a bag recorded with compressed images,
for the mapping nodelet's `compressed` transport."""
import cv2
import numpy as np
import rospy
from sensor_msgs.msg import CompressedImage, Image

TO_BGR = {'rgb8': cv2.COLOR_RGB2BGR, 'bgr8': None, 'mono8': None}


def main():
    rospy.init_node('compress_images')
    kind = rospy.get_param('~format', 'jpeg')  # jpeg or png
    quality = rospy.get_param('~jpeg_quality', 95)
    publisher = rospy.Publisher(rospy.get_param('~output', '/camera/image/compressed'), CompressedImage,
                                queue_size=20)

    def relay(image):
        if image.encoding not in TO_BGR:
            rospy.logerr('compress_images: encoding %s not handled', image.encoding)
            return
        channels = 1 if image.encoding == 'mono8' else 3
        pixels = np.frombuffer(image.data, np.uint8).reshape(image.height, image.step)
        pixels = pixels[:, :image.width * channels].reshape(image.height, image.width, channels)
        if TO_BGR[image.encoding] is not None:
            pixels = cv2.cvtColor(pixels, TO_BGR[image.encoding])
        params = [cv2.IMWRITE_JPEG_QUALITY, quality] if kind == 'jpeg' else []
        ok, data = cv2.imencode('.jpg' if kind == 'jpeg' else '.png', pixels, params)
        if not ok:
            rospy.logerr('compress_images: %s encoding failed', kind)
            return
        target = 'mono8' if channels == 1 else 'bgr8'
        publisher.publish(CompressedImage(header=image.header, format='%s; %s compressed %s' % (
            image.encoding, kind, target if channels == 3 else ''), data=data.tobytes()))
    rospy.Subscriber(rospy.get_param('~input', '/camera/image_bag'), Image, relay, queue_size=20,
                     buff_size=1 << 24)
    rospy.spin()


if __name__ == '__main__':
    main()
