"""dronefleet: the multi-drone control platform of the seed dissertation, rebuilt as software."""

__version__ = "0.1.0"
