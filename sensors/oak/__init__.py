"""Luxonis OAK depth cameras (depthai 3.x): config, bounded device search, the live driver, and the
host-side frame assembly and reconnection it is built on. Importing this package never imports
depthai; the driver does, when it connects."""
