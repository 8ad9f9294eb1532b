"""Test set-up: the test folder on sys.path (for problem_factory) and ROS kept on loopback."""
import os
import sys

sys.path.insert(0, os.path.dirname(__file__))
os.environ.setdefault('ROS_AUTOMATIC_DISCOVERY_RANGE', 'LOCALHOST')
