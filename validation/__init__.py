"""Closed-loop testbed joining the plant and the controller."""
