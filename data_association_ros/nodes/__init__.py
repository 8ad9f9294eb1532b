"""The ROS 2 nodes (rclpy): association_node, ekf_slam_node, box_tracker_node,
lidar_tracker_node, and the parameter handling they share (parameterized_node)."""
