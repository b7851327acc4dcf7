"""Closed-loop testbed joining the plant and the controller. Built in later issues."""
