"""Launch lidar_tracker_node (ros2 launch data_association_ros lidar_tracker.launch.py
[scan:=/scan] [fine:=jcbb_points] [jnis:=cartesian] [publish_markers:=true])."""
from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument
from launch.substitutions import LaunchConfiguration
from launch_ros.actions import Node
from launch_ros.parameter_descriptions import ParameterValue


def generate_launch_description():
    arguments = [
        DeclareLaunchArgument('scan', default_value='scan', description='LaserScan topic'),
        DeclareLaunchArgument('fine', default_value='jcbb_points',
                              description='fine association: jcbb_points or nearest'),
        DeclareLaunchArgument('jnis', default_value='cartesian',
                              description='jNIS coordinates: cartesian or polar'),
        DeclareLaunchArgument('publish_markers', default_value='false',
                              description='publish track_markers'),
    ]
    return LaunchDescription(arguments + [
        Node(package='data_association_ros', executable='lidar_tracker_node',
             name='lidar_tracker_node', output='screen',
             remappings=[('scan', LaunchConfiguration('scan'))],
             parameters=[{'fine': LaunchConfiguration('fine'),
                          'jnis': LaunchConfiguration('jnis'),
                          'publish_markers': ParameterValue(
                              LaunchConfiguration('publish_markers'), value_type=bool)}]),
    ])
