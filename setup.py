"""Packaging: the repository's top-level folders install under one namespace.

``models/``, ``service/``, ``training/`` and ``scenes/`` stay where they are in the repository
(docs/design.md's layout) and install as ``impactnet.models``, ``impactnet.service``,
``impactnet.training`` and ``impactnet.scenes``, so that nothing generic like ``models`` lands at
the top of site-packages. Subpackages are discovered automatically (``find_packages`` per folder);
everything else about the distribution lives in ``pyproject.toml``.
"""
from setuptools import find_packages, setup

#: Repository folder -> installed package name.
ROOTS = {"impactnet": "impactnet", "models": "impactnet.models", "service": "impactnet.service",
         "training": "impactnet.training", "scenes": "impactnet.scenes"}

package_dir, packages = {}, []
for folder, name in ROOTS.items():
    package_dir[name] = folder
    packages += [name, *(f"{name}.{sub}" for sub in find_packages(folder))]

setup(packages=packages, package_dir=package_dir)
