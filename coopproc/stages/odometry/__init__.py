"""The odometer + UWB filter (``odo_uwb``, ``odo_uwb_rts``): a 2D EKF over wheel speeds
with tightly coupled ranges to anchors and IGG-III, and its RTS smoother (paper 003 sec.
2.8); platforms with an odometer (``odo_<ID>.csv``)."""
