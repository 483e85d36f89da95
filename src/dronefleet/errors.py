"""Domain errors that say what went wrong and what kind of wrong it is (issue 11).

Every refusal the ground can give derives from :class:`DronefleetError`; its subclass carries the
meaning (bad input, not found, conflict, ...) and so the HTTP status the REST API answers with,
through one exception handler (:func:`dronefleet.ground.manager.errors.install`). The domain code
never speaks HTTP itself: it raises ``InvalidInput("...")`` and the API layer maps the class.
Anything else that escapes a route is a bug, and only then does a client see a 500.
"""

from __future__ import annotations

from typing import Any, ClassVar


class DronefleetError(Exception):
    """A refusal with a reason; ``extra`` fields travel with it into the error body."""

    #: The HTTP status this kind of error is answered with.
    status: int = 500
    #: A short title for the OpenAPI docs of this status.
    title: ClassVar[str] = "internal error"

    def __init__(self, detail: str, /, **extra: Any) -> None:
        super().__init__(detail)
        self.detail = detail
        self.extra = extra

    def body(self) -> dict[str, Any]:
        return {"detail": self.detail, **self.extra}


class InvalidInput(DronefleetError):
    """The request cannot be done as given: bad geometry, an infeasible plan, a bad value."""

    status = 422
    title = "invalid input (the reason says which)"


class NotFound(DronefleetError):
    """What the request names does not exist (a drone, a mission, a token)."""

    status = 404
    title = "not found"


class Conflict(DronefleetError):
    """The request is valid but the current state forbids it (drone lost or busy, ...)."""

    status = 409
    title = "conflicts with the current state"


class Unavailable(DronefleetError):
    """A service the request needs is not running or not reachable."""

    status = 503
    title = "a service it needs is unavailable"


class NoAnswer(DronefleetError):
    """A drone or ground service did not answer in time (the request may still take effect)."""

    status = 504
    title = "no answer in time"
