"""Launch association_node + ekf_slam_node as a closed loop (ros2 launch data_association_ros
slam.launch.py [algorithm:=jcbb] [association_source:=node] [odometry:=/odom]
[detections:=/landmark_detections]).

ekf_slam_node takes the robot-frame detections on `sensor_observations` and the wheel odometry on
`odometry`, publishes the map, pose and joint covariance and forwards each scan to
association_node on `observations`; it fuses the `correspondences` and `new_landmarks` answers.
"""
from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument
from launch.substitutions import LaunchConfiguration
from launch_ros.actions import Node


def generate_launch_description():
    arguments = [
        DeclareLaunchArgument('algorithm', default_value='jcbb',
                              description='association_node algorithm'),
        DeclareLaunchArgument('association_source', default_value='node',
                              description='node (closed loop) or ground_truth (oracle)'),
        DeclareLaunchArgument('odometry', default_value='odometry',
                              description='nav_msgs/Odometry topic (increment covariances)'),
        DeclareLaunchArgument('detections', default_value='sensor_observations',
                              description='PointCloud2 of robot-frame detections (the scans)'),
    ]
    return LaunchDescription(arguments + [
        Node(package='data_association_ros', executable='association_node',
             name='association_node', output='screen',
             parameters=[{'algorithm': LaunchConfiguration('algorithm')}]),
        Node(package='data_association_ros', executable='ekf_slam_node', name='ekf_slam_node',
             output='screen',
             parameters=[{'association_source': LaunchConfiguration('association_source')}],
             remappings=[('odometry', LaunchConfiguration('odometry')),
                         ('sensor_observations', LaunchConfiguration('detections'))]),
    ])
