"""Scene files (TOML): the bodies and pairs a simulation models. Data only; shipped in the wheel
as ``impactnet/scenes`` and found by :func:`impactnet.models.scenes.scenes_dir`."""
