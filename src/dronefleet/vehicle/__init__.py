"""The vehicle layer: what every side agrees a drone is, below drone/, sim/ and ground/.

The flight-controller contract and its value types (:mod:`.base`), their SI views (:mod:`.views`),
payload types (:mod:`.payload`), and the physics shared by the simulator and the planner's
estimates (:mod:`.kinematics`, :mod:`.battery`). It imports nothing of dronefleet but ``geo``
(docs/DESIGN.md §2).
"""
