"""Test support: real brokers and real drone processes."""
