"""Test set-up: the test folder on sys.path (for the helpers), DDS kept on loopback with a
domain id of this run's own (DESIGN.md 6) and, under pytest-xdist, of each worker's own (two
workers replaying bags on one domain would hear each other's /observations), the compiled JCBB
search built once up front."""
import os
import sys

sys.path.insert(0, os.path.dirname(__file__))
os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'
os.environ.setdefault('ROS_DOMAIN_ID', str(5 + os.getpid() % 90))
_worker = os.environ.get('PYTEST_XDIST_WORKER', '')   # 'gw0', 'gw1', ... (unset: no xdist)
if _worker.startswith('gw'):
    # the next ids after the run's own, within 5-94 as setup_env.sh chooses them
    os.environ['ROS_DOMAIN_ID'] = str(
        5 + (int(os.environ['ROS_DOMAIN_ID']) - 5 + 1 + int(_worker[2:])) % 90)


def pytest_sessionstart(session):
    """Compile the JCBB kernels (or load them from numba's cache) once, in this process, before
    any test: node processes the tests start then load them from the cache instead of compiling
    them within their start-up timeouts (a fresh clone has no cache)."""
    from data_association_ros.core.associators import jcbb_compiled
    jcbb_compiled.available()
