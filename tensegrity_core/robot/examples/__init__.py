"""The shipped robots (package data): see ``tensegrity_core.robot.loading.robot_names``."""
