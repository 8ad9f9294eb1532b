"""DDS kept on loopback for the tools that start their own little ROS graph (DESIGN.md 6)."""
from __future__ import annotations

import os
import random


def use_loopback_dds() -> str:
    """Set ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST and, unless set, a ROS_DOMAIN_ID of this run's
    own (10-99); call before rclpy.init. Returns the domain id."""
    os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'
    os.environ.setdefault('ROS_DOMAIN_ID', str(random.Random(os.getpid()).randint(10, 99)))
    return os.environ['ROS_DOMAIN_ID']
