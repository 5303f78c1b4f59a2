"""The one packaging rule pyproject.toml cannot say: the top-level ``resources/`` folder is
installed as the package data ``camcmm/resources``.

setuptools' ``packages.find`` cannot rename a folder into a package, so the package list is
made here; everything else (metadata, dependencies, entry points, package data) is in
pyproject.toml. ``camcmm.assets.resources_dir()`` finds the installed copy through
importlib.resources, and the checkout's folder in an editable install.
"""

from setuptools import find_namespace_packages, setup

PACKAGES = [
    *find_namespace_packages("app", include=["camcmm", "camcmm.*"], exclude=["*.__pycache__"]),
    *find_namespace_packages("plugins", include=["camcmm_plugins", "camcmm_plugins.*"], exclude=["*.__pycache__"]),
    "camcmm.resources",
    *(f"camcmm.resources.{sub}" for sub in find_namespace_packages("resources", exclude=["*.__pycache__"])),
]

setup(
    packages=PACKAGES,
    package_dir={"camcmm": "app/camcmm", "camcmm_plugins": "plugins/camcmm_plugins", "camcmm.resources": "resources"},
)
