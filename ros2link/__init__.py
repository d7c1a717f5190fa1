"""The link to a ROS 2 system (docs/ros2.md): rmw_zenoh's wire format (`rmw`), one ROS 2 node's session (`node`),
the standard messages' codec (`cdr`), and a ROS 2 image topic as a stream of frames (`camera`, the coordinator's
live source). The run's ROS 2 messages and live bridge are the recorder's (fluidswarm/recording/ros2_messages.py,
ros2_bridge.py); its bags and options the command line's (fluidswarm/ros2_bag.py, ros2_options.py).

A top-level package, below the coordinator and the recorder that use it (docs/architecture.md's layers), named
`ros2link` rather than `ros2`: a ROS 2 installation may put a package of that name on sys.path."""
