"""Position methods from raw GPS observations (``tight``, ``tight_kf``, ``gnss``,
``gnss_kf``): the tightly coupled GPS/UWB robust Kalman filter of paper 002, with the INS
error states for a platform with an IMU, and its DOP. The observation models and
ephemerides stay below the stages in :mod:`coopproc.gnss`."""
