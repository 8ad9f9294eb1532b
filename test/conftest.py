"""Test set-up: the test folder on sys.path (for the helpers) and DDS kept on loopback with a
domain id of this run's own (DESIGN.md 6)."""
import os
import sys

sys.path.insert(0, os.path.dirname(__file__))
os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'
os.environ.setdefault('ROS_DOMAIN_ID', str(5 + os.getpid() % 90))
