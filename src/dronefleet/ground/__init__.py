"""The ground side of the seed's architecture (Fig. 3.7): Drone Identifier, Drone Manager,
Telemetry Analyzer, and the state store they share. Each talks to the others over the ground broker.
"""
