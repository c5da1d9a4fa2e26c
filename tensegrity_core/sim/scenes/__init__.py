"""The shipped simulation scenes (package data; see ``tensegrity_core.sim.scene_names``)."""
