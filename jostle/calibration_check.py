"""Before a run: each webcam or depth observer's calibration against the image size its sensor gives.

Called once the sensors are open (a video file, a recording or a camera then reports its real size,
:class:`sensors.base.SensorSpec`): a calibration made for another size of the same shape is rescaled
with a warning, one for another shape stops the run with one line naming the file and both sizes
(:func:`interaction.webcam.calibration_size.fit_to_image_size`). A sensor that does not know its size
yet leaves the check to the observer, frame by frame.
"""

from __future__ import annotations

from pathlib import Path

from interaction.webcam.calibration import Calibration
from interaction.webcam.calibration_size import fit_to_image_size
from interaction.webcam.floor_calibration import FloorCalibration, load_webcam_calibration
from jostle.config import ObserverEntry
from sensors.base import Sensor


def calibration_for(ob: ObserverEntry, sensor: Sensor) -> Path | Calibration | FloorCalibration | None:
    """What observer ``ob`` is built with: its calibration file, or the calibration rescaled to the
    images of ``sensor`` (raises CalibrationError for images of another shape)."""
    if ob.type not in ("webcam", "depth") or ob.calibration is None:
        return ob.calibration
    spec = sensor.spec
    if spec.width is None or spec.height is None:
        return ob.calibration
    if ob.type == "depth":  # in metres, so another scale is the same camera; another shape is refused
        from interaction.depth.calibration import DepthCalibration
        from sensors.untrusted import UntrustedInput

        try:
            DepthCalibration.load(ob.calibration).fits_image((spec.width, spec.height))
        except UntrustedInput as e:
            raise UntrustedInput(str(ob.calibration), f"{e.problem} (sensor {ob.sensor!r})") from None
        return ob.calibration
    loaded = load_webcam_calibration(ob.calibration)  # an upright plane or the floor
    fitted = fit_to_image_size(loaded, (spec.width, spec.height), file=ob.calibration,
                               images=f"sensor {ob.sensor!r}")
    return ob.calibration if fitted is loaded else fitted
