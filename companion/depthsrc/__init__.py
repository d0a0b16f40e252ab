"""Depth sources: adapters that turn a camera's, a bag's or the stub's frames into DepthFrames
(core/perception/depth_frame.py) with their capture time. ``open_depth_source`` picks one from a
``perception.depth.source`` (config/depth_perception.py). No maths here: the pixels go to
core/perception/depth_perception.py unchanged (a 32FC1 image is only converted to Z16)."""
