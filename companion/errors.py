"""The project's small exception hierarchy: their faults (bad input) versus our own bugs."""


class CompanionError(Exception):
    """Base of every error this package raises on purpose."""


class ConfigError(CompanionError):
    """A configuration or scenario file is malformed; the message names file, key and problem."""


class LinkError(CompanionError):
    """The MAVLink link could not be opened or was lost for good."""


class EstimatorError(CompanionError):
    """The estimator diverged (non-finite mean, covariance not positive semi-definite)."""


class ShutdownRequested(CompanionError):
    """Raised by the stop task so the TaskGroup cancels its siblings on SIGINT/SIGTERM."""
