"""MAVLink as both sides speak it: the codec (pymavlink's ArduPilot dialect), mission items and
ArduPilot/PX4 flight modes."""
