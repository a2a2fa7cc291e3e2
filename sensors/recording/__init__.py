"""Recordings: sensor frames written to and played back from MCAP files.

``writer`` records frames, ``codec`` maps payloads to Foxglove messages, ``chunks`` opens one chunk
within its decompression budget and finds the next good one past damage, ``stream`` and ``index``
read a file record by record or from its summary, ``info`` describes what a file holds (and what was
lost), ``source`` shares one open file between its replays and yields its frames, ``replay`` plays
one channel as a Sensor on the loop's clock, and ``damage`` measures how much of a damaged file is kept.
"""
