"""The shipped gaits (package data): see ``tensegrity_core.robot.gait.gait_names``."""
