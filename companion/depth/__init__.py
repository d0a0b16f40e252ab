"""Depth sources: adapters that turn a camera's, a bag's or the stub's frames into DepthFrames
(core/perception/depth_frame.py)."""
