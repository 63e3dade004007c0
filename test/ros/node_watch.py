"""What the rostest checkers share: the mapping nodelet's diagnostics as a
dict, waiting on a condition with a wall-clock timeout, topic recording and
its Trigger services."""
import threading
import time
import xmlrpc.client

import rosgraph

import rospy
from diagnostic_msgs.msg import DiagnosticArray
from std_srvs.srv import Trigger


def rss_mb(node):
    """Resident memory of a ROS node on this machine, from its pid (XML-RPC getPid)."""
    caller = rospy.get_name()
    uri = rosgraph.Master(caller).lookupNode(node)
    _, _, pid = xmlrpc.client.ServerProxy(uri).getPid(caller)
    with open('/proc/%d/status' % pid) as status:
        for line in status:
            if line.startswith('VmRSS:'):
                return int(line.split()[1]) / 1024.0
    return float('nan')


class NodeWatch:
    def __init__(self, node):
        self.node = node
        self.lock = threading.Lock()
        self.diagnostics = {}
        self.level = None    # of the node's status: 0 OK, 1 WARN, 2 ERROR
        self.message = ''    # its summary
        self.stamp = None    # of its last message (the node's ros::Time::now(): simulated time follows /clock)
        self.recorded = {}
        rospy.Subscriber('/diagnostics', DiagnosticArray, self._diagnostics)

    def _diagnostics(self, msg):
        for status in msg.status:
            if 'depth estimation' in status.name:
                with self.lock:
                    self.diagnostics = {kv.key: kv.value for kv in status.values}
                    self.level, self.message = status.level, status.message
                    self.stamp = msg.header.stamp.to_sec()

    def record(self, topic, kind):
        """Every message on `topic` from now on, in self.recorded[topic]."""
        self.recorded[topic] = []

        def append(msg):
            with self.lock:
                self.recorded[topic].append(msg)
        rospy.Subscriber(topic, kind, append, queue_size=50, buff_size=1 << 26)
        return self.recorded[topic]

    def wait_for(self, predicate, timeout=60.0):
        """Polls predicate() under the lock until true or timeout (wall
        seconds: simulated time may stand still)."""
        deadline = time.time() + timeout
        while time.time() < deadline:
            with self.lock:
                if predicate():
                    return True
            time.sleep(0.1)
        return False

    def count(self, key):
        return int(float(self.diagnostics.get(key, '0')))

    def call(self, name, kind=Trigger, *args):
        rospy.wait_for_service(self.node + '/' + name, timeout=10)
        return rospy.ServiceProxy(self.node + '/' + name, kind)(*args)
