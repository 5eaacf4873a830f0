"""The one error the peer reports to its user."""


class Failure(Exception):
    """A problem with the user's input (bank, measurement, arguments): printed, exit 1."""
