"""In-repo MAVLink SITL stub: the paper's 2D model behind an ArduCopter-like MAVLink face.

An independent peer of `companion`: it never imports it (see /work/shared/STYLE.md).
"""
