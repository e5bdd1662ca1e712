"""Error types: every problem a user can act on is one of these."""

__all__ = ["CreepcompError", "InputError", "NotRealisableError"]


class CreepcompError(Exception):
    """Base class of the project's errors; the message is meant for the user."""


class InputError(CreepcompError, ValueError):
    """A value, file or option given by the user is wrong; the message says which and where."""


class NotRealisableError(CreepcompError):
    """A creep model that the requested network topology cannot cancel."""
