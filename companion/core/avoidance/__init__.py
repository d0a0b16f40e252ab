"""Guidance on the estimate: collision cones, their union, the velocity choice, where to look."""
