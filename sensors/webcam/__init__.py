"""Webcams, video files and video streams through OpenCV (imported only by ``driver.py``)."""
