"""Flight Controller Interface: one protocol, several backends (sim, mavlink, uavtalk)."""
