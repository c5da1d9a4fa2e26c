"""Shipped tables of tipping moves (:mod:`tensegrity_core.robot.roll_control`)."""
