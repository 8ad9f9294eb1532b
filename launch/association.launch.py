"""Launch association_node with config/association.yaml (ros2 launch data_association_ros
association.launch.py [params_file:=...])."""
import os

from ament_index_python.packages import get_package_share_directory
from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument
from launch.substitutions import LaunchConfiguration
from launch_ros.actions import Node


def generate_launch_description():
    default_params = os.path.join(get_package_share_directory('data_association_ros'), 'config',
                                  'association.yaml')
    return LaunchDescription([
        DeclareLaunchArgument('params_file', default_value=default_params,
                              description='parameter file of association_node'),
        Node(package='data_association_ros', executable='association_node',
             name='association_node', output='screen',
             parameters=[LaunchConfiguration('params_file')]),
    ])
