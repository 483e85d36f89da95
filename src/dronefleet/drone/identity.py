"""A drone's id: given by the user, or from the last 3 bytes of the MAC address (seed 4.1.2)."""

from __future__ import annotations

import uuid

from dronefleet.messaging.topics import check_drone_id


def default_drone_id(prefix: str = "DRONE") -> str:
    """e.g. ``DRONE_94E041`` — like the seed's ``REVOLUTION_94E041``."""
    return check_drone_id(f"{prefix}_{uuid.getnode() & 0xFFFFFF:06X}")
