"""ament_python build of data_association_ros (also installable with pip)."""
import os
from glob import glob

from setuptools import find_packages, setup

package_name = 'data_association_ros'

setup(
    name=package_name,
    version='0.1.0',
    packages=find_packages(include=['data_association_ros', 'data_association_ros.*',
                                    'msg_adapters', 'msg_adapters.*']),
    data_files=[
        ('share/ament_index/resource_index/packages', ['resource/' + package_name]),
        ('share/' + package_name, ['package.xml']),
        ('share/' + package_name + '/config', glob('config/*.yaml')),
        ('share/' + package_name + '/launch', glob('launch/*.launch.py')),
        *[('share/' + package_name + '/' + bag, glob(bag + '/*'))
          for bag in glob('bags/*') if os.path.isdir(bag)],
    ],
    python_requires='>=3.10',
    install_requires=['setuptools', 'numpy', 'scipy', 'mcap', 'pyyaml'],
    zip_safe=True,
    maintainer='data_association_ros developers',
    maintainer_email='dev@data-association-ros.invalid',
    description='Data association (NN, ML, GNN, JCBB, IoU) as a ROS 2 node and a numpy library.',
    license='Apache-2.0',
    extras_require={'test': ['pytest', 'hypothesis'], 'fast': ['numba'],
                    'benchmarks': ['matplotlib', 'stonesoup'], 'mot': ['trackeval']},
    entry_points={
        'console_scripts': [
            'association_node = data_association_ros.nodes.association_node:main',
            'box_tracker_node = data_association_ros.nodes.box_tracker_node:main',
            'ekf_slam_node = data_association_ros.nodes.ekf_slam_node:main',
            'da_slam_eval = data_association_ros.bag.slam_eval:main',
            'lidar_tracker_node = data_association_ros.nodes.lidar_tracker_node:main',
            'da_lidar_eval = data_association_ros.bag.lidar_eval:main',
            'da_make_mot_bag = data_association_ros.bag.mot:make_main',
            'da_mot_eval = data_association_ros.bag.mot:eval_main',
            'da_demo = data_association_ros.demo:main',
            'da_bag_replay = data_association_ros.bag.replay:main',
            'da_bag_eval = data_association_ros.bag.evaluate:main',
            'da_make_bags = data_association_ros.bag.make_bags:main',
        ],
    },
)
