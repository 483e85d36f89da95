"""The drone side of the seed's architecture (Figure 3.2): controller, gear, fail-safe, logger."""
