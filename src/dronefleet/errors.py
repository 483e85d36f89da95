"""Domain errors that say what went wrong and what kind of wrong it is (issue 11).

Every exception the project defines derives from :class:`DronefleetError` (a test walks the package
to keep it so), through one of the kinds below, which say what kind of wrong it is: bad input,
not found, a conflict with the current state, a part unavailable, no answer in time. Each carries
its reason. The domain code never speaks HTTP: the Drone Manager maps the kinds to statuses in one
place (ground/manager/errors.py). Anything else that escapes a route is a bug, and only then does
a client see a 500.
"""

from __future__ import annotations

from typing import Any


class DronefleetError(Exception):
    """A refusal or failure with a reason; ``extra`` fields travel with it (into an error body)."""

    def __init__(self, detail: str, /, **extra: Any) -> None:
        super().__init__(detail)
        self.detail = detail
        self.extra = extra

    def body(self) -> dict[str, Any]:
        return {"detail": self.detail, **self.extra}


class InvalidInput(DronefleetError):
    """The request cannot be done as given: bad geometry, an infeasible plan, a bad value."""


class NotFound(DronefleetError):
    """What the request names does not exist (a drone, a mission, a token)."""


class Conflict(DronefleetError):
    """The request is valid but the current state forbids it (drone lost or busy, ...)."""


class Unavailable(DronefleetError):
    """A service the request needs is not running or not reachable."""


class Failed(DronefleetError):
    """Something that was tried did not work (a step, an experiment, a link)."""


class NoAnswer(DronefleetError):
    """A drone or ground service did not answer in time (the request may still take effect)."""
