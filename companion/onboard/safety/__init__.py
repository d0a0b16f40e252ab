"""The safety-relevant state of the pipeline, one question per module (docs/robustness.md):

- :mod:`clock`     is this vehicle time believable, and did the vehicle reboot?
- :mod:`liveness`  is the vehicle's heartbeat fresh, is the camera's obstacle data stale?
- :mod:`gate`      may this setpoint leave (every field finite and within the limits)?

Each takes time as an argument, does no I/O and returns a decision with its reason.
"""
