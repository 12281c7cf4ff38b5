"""`impactnet show`: look at one pose of a scene's pair with its part contacts, as a PNG
(matplotlib) and a GLB (trimesh). Issue #20, step 6."""
