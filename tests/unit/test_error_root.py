"""One error root (issue 15): every exception the project defines is a DronefleetError of a kind."""

from __future__ import annotations

import importlib
import inspect
import pkgutil

import dronefleet
from dronefleet.errors import DronefleetError


def _exceptions() -> list[type[BaseException]]:
    found = []
    for info in pkgutil.walk_packages(dronefleet.__path__, "dronefleet."):
        if info.name.endswith("__main__"):
            continue
        module = importlib.import_module(info.name)
        for _, obj in inspect.getmembers(module, inspect.isclass):
            if issubclass(obj, BaseException) and obj.__module__ == module.__name__:
                found.append(obj)
    return found


def test_every_exception_of_the_project_derives_from_the_root():
    exceptions = _exceptions()
    assert len(exceptions) > 20  # the walk saw the package
    outside = [f"{e.__module__}.{e.__qualname__}" for e in exceptions]
    outside = [
        n for e, n in zip(exceptions, outside, strict=True) if not issubclass(e, DronefleetError)
    ]
    assert not outside, f"not under DronefleetError: {outside}"


def test_each_kind_maps_to_one_http_status_in_the_managers_error_module():
    from dronefleet.drone.fc.uavtalk.link import Refused
    from dronefleet.ground.manager.errors import status_of
    from dronefleet.messaging.client import BrokerUnavailable
    from dronefleet.messaging.codec import MessageError
    from dronefleet.messaging.rpc import RequestTimeout
    from dronefleet.vehicle.base import FcError

    assert status_of(MessageError("bad")) == 422
    assert status_of(Refused("no")) == 409
    assert status_of(BrokerUnavailable("down")) == 503
    assert status_of(RequestTimeout("late")) == 504
    assert status_of(FcError("broke")) == 500  # a failure escaping a route is a bug
