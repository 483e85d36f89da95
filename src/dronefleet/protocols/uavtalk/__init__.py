"""UAVTalk (the seed's dRonin/OpenPilot protocol) as both sides speak it: framing, UAVObject
definitions and their registry, and ``tcp:HOST:PORT`` addresses."""
