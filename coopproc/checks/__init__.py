"""Checks of a loaded session before processing: navigation coverage of the ranges and
the navigation frame of each platform."""
