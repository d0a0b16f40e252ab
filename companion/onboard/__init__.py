"""The service's decisions without I/O: the pipeline from decoded messages to intents, and its parts."""
