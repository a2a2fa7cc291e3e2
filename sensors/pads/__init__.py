"""Serial force pads: a board sends raw counts per pad, the driver turns them into newtons.

``config.py`` (PadsConfig), ``protocol.py`` (the wire formats as a table, the stream parser) and
``calibration.py`` import no hardware backend; only ``driver.py`` imports pyserial, and only the
registry's loader imports it, when a config selects ``type = "pads"``.
"""
