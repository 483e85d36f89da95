"""What the drones photographed, kept on the ground per mission (issue 14).

The seed's aerial photography experiment (5.2) left its pictures on the drones. Here the ground
fetches each picture a ``takepic`` reports (collector.py, over the Gear Manager's ``photo``
queries), keeps it byte for byte (GPS EXIF intact) in its state folder with a thumbnail
(store.py, images.py), and serves the list, each picture, its thumbnail and a zip of them all for
photogrammetry tools such as OpenDroneMap (api.py).
"""
