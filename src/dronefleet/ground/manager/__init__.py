"""Drone Manager (seed 3.4.2.2, 4.2.3): the REST API, the seed's ``/control`` and a live stream."""
