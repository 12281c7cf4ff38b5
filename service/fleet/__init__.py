"""Running several replicas behind one nginx front (docs/fleet.md): the front's configuration
rendered from the shipped template (:mod:`.nginx_conf`) and a loopback fleet launcher
(:mod:`.local`)."""
