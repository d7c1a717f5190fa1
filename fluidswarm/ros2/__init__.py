"""The run on ROS 2 (docs/ros2.md): rmw_zenoh's format, the standard messages, the live bridge, bags, a ROS 2 camera."""
