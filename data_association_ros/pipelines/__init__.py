"""What the nodes do per message, without rclpy: the association pipeline, the SLAM pipeline,
their parameters, statistics and stamp-matched buffers (usable offline on a bag)."""
