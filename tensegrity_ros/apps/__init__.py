"""Applications built from the nodes: the demo (:mod:`.demo`) and the launcher that starts
several suite processes together (:mod:`.launch`)."""
