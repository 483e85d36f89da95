"""The mission steps a Drone Controller does not run itself (seed Table 4.3): waiting for the
flight to reach its goal, a virtual alarm, and reading the sensors at a waypoint. The Mission
Worker (drone/mission_worker.py) runs each step through :func:`execute`, which hands the control
commands to the Drone Controller and the rest to these."""

from __future__ import annotations

import contextlib
from typing import TYPE_CHECKING, Any

from dronefleet.drone.controller import CommandError
from dronefleet.drone.navigation import Tolerance
from dronefleet.drone.state import position_of
from dronefleet.errors import Failed
from dronefleet.messaging.commands import CONTROL_COMMANDS, Command
from dronefleet.messaging.gear import GearQuery
from dronefleet.messaging.status import Alarm
from dronefleet.messaging.topics import Channel

if TYPE_CHECKING:
    from dronefleet.drone.controller import DroneController
    from dronefleet.drone.outbox import Outbox


class StepFailed(Failed):
    pass


async def wait_for_flight(controller: DroneController, step: Any) -> dict[str, Any]:
    """Until the goal the last navigate step set is reached within the step's tolerances (or
    the configured ones); fails on its timeout, or when the vehicle disarms meanwhile."""
    config, clock = controller.config, controller.clock
    tolerance = Tolerance(
        step.horizontal_tolerance_m or config.horizontal_tolerance_m,
        step.vertical_tolerance_m or config.vertical_tolerance_m,
    )
    nav = controller.navigation
    deadline = None if step.timeout_s is None else clock.now() + step.timeout_s
    while not nav.goal_reached(tolerance):
        if deadline is not None and clock.now() >= deadline:
            raise StepFailed(
                f"goal not reached within {step.timeout_s:g} s "
                f"({nav.distance_to_goal_m():.1f} m away)"
            )
        state = controller.fc.state()
        if not state.armed and not state.arming:
            raise StepFailed("vehicle disarmed while waiting for flight")
        await clock.sleep(config.wait_poll_s)
    return {"distance_m": round(nav.distance_to_goal_m(), 3)}


def virtual_alarm(
    controller: DroneController, outbox: Outbox, step: Any, mission_id: str | None
) -> dict[str, Any]:
    """Raise the step's alarm as if the drone had measured it (the seed's experiments 2 and 4)."""
    fc = controller.fc
    alarm = Alarm(
        drone_id=controller.drone_id,
        level=step.level,
        message=step.message or f"virtual {step.level} alarm",
        position=position_of(fc.position(), fc.home()),
        mission_id=mission_id,
        step_index=controller.step_index,
        virtual=True,
        vehicle_time_s=round(controller.clock.now(), 3),
    )
    outbox.post(controller.topic(Channel.ALARMS), alarm)
    return {"alarm": str(step.level)}


class SensorReadings:
    """read_sensors steps: every sensor the Gear Manager lists, read at the waypoint. The list is
    asked once per mission, not at every waypoint."""

    def __init__(self, controller: DroneController) -> None:
        self.controller = controller
        self._names: list[str] | None = None

    def forget(self) -> None:
        """A new mission asks for the sensor list again."""
        self._names = None

    async def read(self, step: Any) -> dict[str, Any]:
        if step.value:
            await self.controller.clock.sleep(step.value)
        if self._names is None:
            try:
                sensors = (await self.controller.gear(GearQuery.SENSORS)).get("sensors") or {}
            except CommandError as exc:  # the Gear Manager unreachable (its broker away)
                # A reading missed is recorded; the mission flies on (issue 13).
                return {"readings": {}, "error": str(exc)}
            self._names = sensor_names(sensors)
        readings = {}
        for name in self._names:
            with contextlib.suppress(CommandError):
                readings[name] = (await self.controller.gear(GearQuery.READING, name)).get(
                    "reading"
                )
        return {"readings": readings}


def sensor_names(sensors: dict[str, Any]) -> list[str]:
    """Sensor keys of a Listing 4.2 sensor list: nested groups ({"GAS": {"CO2": ...}}) flattened."""
    names: list[str] = []
    for key, value in sensors.items():
        if isinstance(value, dict):
            names.extend(value.keys())
        elif key.upper() != "CAMERA":
            names.append(key)
    return names


async def execute(
    controller: DroneController,
    step: Any,
    outbox: Outbox,
    sensors: SensorReadings,
    mission_id: str | None,
) -> dict[str, Any]:
    """Run one step: control commands go to the controller; the rest are handled here."""
    if step.command in CONTROL_COMMANDS:
        return await controller.execute(step)
    match step.command:
        case Command.WAIT_FOR_FLIGHT:
            return await wait_for_flight(controller, step)
        case Command.SLEEP:
            await controller.clock.sleep(step.value)
            return {"slept_s": step.value}
        case Command.VIRTUALALARM:
            return virtual_alarm(controller, outbox, step, mission_id)
        case Command.READ_SENSORS:
            return await sensors.read(step)
        case Command.CAMERA_TRIGGER:
            return await controller.camera_trigger.set_distance(step.value)
    raise StepFailed(f"step command {step.command!r} is not supported")
