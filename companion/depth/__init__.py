"""Depth sources: adapters that turn a camera's, a bag's or the stub's frames into DepthFrames
(core/perception/depth_frame.py). ``open.open_depth_source`` picks one from a
``perception.depth.source`` (config/depth_perception.py): the stub's stream (stub_stream.py),
ROS bags (rosbag.py), RealSense recordings and cameras (realsense.py)."""
