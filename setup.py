"""The package list, found by setuptools rather than written by hand (a hand-kept list left
``pneucore.identify`` and ``pneucore.analysis.diagnosis`` out of the wheel): every package
under ``pneucore/`` and ``app/``, and the page's files (the repository's ``static/``) carried
as ``app.static`` so that a wheel serves the page too. Everything else is in pyproject.toml."""
from setuptools import find_packages, setup

setup(packages=find_packages(include=["pneucore", "pneucore.*", "app", "app.*"]) + ["app.static"],
      package_dir={"app.static": "static"})
