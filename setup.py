"""Package layout that pyproject.toml cannot state on its own: setuptools
finds every package under src/ (so a new analysis subpackage is installed
without being listed), and the model modules in models/ are installed as
loomfmu.models."""
from setuptools import find_packages, setup

setup(
    packages=find_packages("src") + ["loomfmu.models"],
    package_dir={"": "src", "loomfmu.models": "models"},
)
