"""Wire protocols spoken to autopilots, below drone/ (which speaks them) and sim/ (which serves
them): MAVLink's codec, mission items and flight modes; UAVTalk's framing, object definitions and
registry (docs/DESIGN.md §2)."""
