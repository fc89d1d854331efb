"""Raw GNSS: RINEX readers, broadcast ephemerides, corrections and single-point
positioning (issue 13)."""
