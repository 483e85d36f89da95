"""Telemetry Analyzer (seed 3.4.2.3, 4.2.2): broker-to-database connector and time-series stores."""
