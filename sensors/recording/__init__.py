"""Recordings: sensor frames written to and played back from MCAP files.

``writer`` records frames, ``codec`` maps payloads to Foxglove messages, ``stream`` and ``index``
read a file record by record or from its summary, ``info`` describes what a file holds, ``source``
shares one open file between its replays and yields its frames, and ``replay`` plays one channel as
a Sensor on the loop's clock.
"""
