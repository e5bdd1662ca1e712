"""Error types: every problem a user can act on is one of these."""

__all__ = ["CreepcompError", "InputError", "NotApplicable", "NotRealisableError"]


class CreepcompError(Exception):
    """Base class of the project's errors; the message is meant for the user."""


class InputError(CreepcompError, ValueError):
    """A value, file or option given by the user is wrong; the message says which and where."""


class NotApplicable(InputError):
    """A candidate effect that has nothing to describe in this record (no jump to fit, no
    column it needs): not a failure of its fit. The message says why."""


class NotRealisableError(CreepcompError):
    """A creep model that the requested network topology cannot cancel."""
